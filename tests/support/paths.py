"""Where the tests find the checkout: ROOT (the add-on's folder, holding the cmmsampling
package), TESTS (tests/), DATA (tests/data/)."""
import os

TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.dirname(TESTS)
DATA = os.path.join(TESTS, "data")
