"""Golden answers of the exact solvers: seeded sets, margins, recorder and comparison rule
(``python -m tests.golden.record``; the tests are ``tests/models/*/test_golden.py``)."""
