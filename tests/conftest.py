"""Suite-wide settings.

BLAS runs single-threaded in the tests, as it does inside the library's trials and
diagnoses: the matrices are small (hundreds of DOFs), where OpenBLAS threads only spin,
and on a loaded 2-core machine that spinning made single tests 17 times slower.
"""

import pytest
from threadpoolctl import threadpool_limits


@pytest.fixture(autouse=True, scope="session")
def _single_threaded_blas():
    with threadpool_limits(limits=1, user_api="blas"):
        yield
