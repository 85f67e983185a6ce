# Performance verification (issue 13): geometric fitting (aacmm.geometry), the
# ISO 10360-12 / ASME B89.4.22 evaluations (aacmm.verification) and the
# aacmm verify / fit / export commands.
#   test-geometry     published (Gander-Golub-Strebel) and self-certifying data for
#                     every fit, bias over 1,000 noisy caps, minimum zone, bad input
#   test-verify       the verification quantities and decision rules; verify, fit and
#                     export on synthetic sessions against an independent recomputation
#                     from the raw counts, the PDF page rasterised (pdftoppm); on the
#                     simulator (aacmm sim --truth --scenario + aacmm capture): a perfect
#                     arm within its noise, a random arm failing as its truth predicts,
#                     the same arm passing after aacmm calibrate; an aluminium arm
#                     calibrated at 20 degC verified at 28 degC, with and without
#                     thermal compensation (issue 27, tests/host/thermal_study.py); the
#                     device's link temperatures in sessions, verify and calibrate; end to
#                     end on the simulator: an aluminium arm at 28 degC compensated by the
#                     device's thermal block vs none and vs 20 degC, TEMP_FAULT in capture
#   test-verify-lint  ruff, ruff format, mypy --strict over the above

VERIFY_PY_FILES := host/src/aacmm/geometry host/src/aacmm/verification \
                   host/src/aacmm/commands/verify.py host/src/aacmm/commands/verify_report.py \
                   host/src/aacmm/commands/fit.py host/src/aacmm/records/measured.py \
                   tests/host/test_geometry.py tests/host/selfcert.py \
                   tests/host/test_verification.py tests/host/test_verify_cli.py \
                   tests/host/verify_sessions.py tests/host/verify_predict.py \
                   tests/host/test_verify_sim.py scripts/verification_figures.py \
                   tests/host/test_thermal_verify.py tests/host/thermal_study.py \
                   tests/host/test_device_temps.py tests/host/test_device_temps_sim.py
VERIFY_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -c host/pyproject.toml --rootdir=.

.PHONY: test-geometry test-verify test-verify-lint verification-figures

#> test-geometry        fits vs published and self-certifying data, cap bias, minimum zone
test-geometry:
	$(VERIFY_PYTEST) tests/host/test_geometry.py

#> test-verify          verification quantities, rules; verify/fit/export on synthetic and simulator sessions; 20 to 28 degC
test-verify: sim
	$(VERIFY_PYTEST) tests/host/test_verification.py tests/host/test_verify_cli.py \
	    tests/host/test_verify_sim.py tests/host/test_thermal_verify.py \
	    tests/host/test_device_temps.py tests/host/test_device_temps_sim.py

#> test-verify-lint     ruff, ruff format, mypy --strict on geometry, verification, their commands
test-verify-lint:
	$(call py_lint,$(VERIFY_PY_FILES))

#> verification-figures regenerate the figures of docs/verification.md
verification-figures:
	$(PYTHON) scripts/verification_figures.py

TEST_SUITES += test-geometry test-verify test-verify-lint
