# Performance verification (issue 13): geometric fitting (aacmm.geometry), the
# ISO 10360-12 / ASME B89.4.22 evaluations (aacmm.verification) and the
# aacmm verify / fit / export commands.
#   test-geometry     published (Gander-Golub-Strebel) and self-certifying data for
#                     every fit, bias over 1,000 noisy caps, minimum zone, bad input
#   test-verify       the verification quantities and decision rules on synthetic data
#   test-verify-lint  ruff, ruff format, mypy --strict over the above

VERIFY_PY_FILES := host/src/aacmm/geometry host/src/aacmm/verification \
                   tests/host/test_geometry.py tests/host/selfcert.py tests/host/test_verification.py
VERIFY_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=.

.PHONY: test-geometry test-verify test-verify-lint

test-geometry:
	$(VERIFY_PYTEST) tests/host/test_geometry.py

test-verify:
	$(VERIFY_PYTEST) tests/host/test_verification.py

test-verify-lint:
	$(VENV)/bin/ruff check --config host/pyproject.toml $(VERIFY_PY_FILES)
	$(VENV)/bin/ruff format --check --config host/pyproject.toml $(VERIFY_PY_FILES)
	$(VENV)/bin/mypy --config-file host/pyproject.toml $(VERIFY_PY_FILES)

TEST_SUITES += test-geometry test-verify test-verify-lint
