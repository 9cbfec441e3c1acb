"""The capabilities ``rperc bench`` scores, one module each: what a task of the suite
runs (``run``), what its table shows first (``SHOWN``) and its figure's metric
(``PRIMARY``)."""
