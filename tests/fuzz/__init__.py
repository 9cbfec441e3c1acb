"""The fuzz suite of issue 15: hypothesis properties over every public entry point and
malformed-file generators for every loader. The properties live in ``props_*`` modules
and run in child processes (``tests/test_fuzz.py``) under a memory and time limit, so an
abort or a hang fails a test instead of killing the run."""
