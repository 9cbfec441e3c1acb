"""Examples that abort, hang or eat memory on purpose: tests/test_fuzz.py checks that the
harness reports each as a failure with the example that was running, instead of
dying with it or waiting forever."""

from __future__ import annotations

import os
import time

from hypothesis import given
from hypothesis import strategies as st

from fuzz.harness import case, examples


@examples(5)
@given(st.integers(0, 3))
def prop_abort(k):
    case("abort", k=k)
    if k >= 0:
        os.abort()


@examples(5)
@given(st.integers(0, 3))
def prop_hang(k):
    case("hang", k=k)
    time.sleep(3600)


@examples(5)
@given(st.integers(0, 3))
def prop_allocate(k):
    """Beyond RLIMIT_AS: a MemoryError, which is no failure of the harness."""
    case("allocate", k=k)
    try:
        bytearray(8 << 30)
    except MemoryError:
        return
    raise AssertionError("8 GiB allocated under a 2 GiB address-space limit")
