"""Where the Python tests find their data: set by python/CMakeLists.txt (ctest), or by hand:
SVMS_BINARY (build/bin/svms), SVMS_TEST_DATA (the python_test_data fixture's directory),
SVMS_CAPI_FIXTURE (the capi_fixture test's directory)."""
import os
import unittest


def need(variable):
    """The path an environment variable names. Unset: the test is skipped (a run by hand);
    set to a path that does not exist (a fixture that failed): an error, never a silent skip."""
    value = os.environ.get(variable, "")
    if not value:
        raise unittest.SkipTest(f"{variable} is not set (ctest sets it: ctest -R python)")
    if not os.path.exists(value):
        raise FileNotFoundError(f"{variable}: {value} does not exist (did its ctest fixture run?)")
    return value
