# The arm in the browser (issue 28): aacmm.view, aacmm view, capture --view and the
# HTML reports, tested in Debian's headless Chromium (Playwright drives
# /usr/bin/chromium; nothing is downloaded).
#   test-view       tests/host/test_view.py against the simulator and its operator:
#                   the live tip within 2 mm of the device's at every press, points on
#                   the page within 1 s, two pages, a browser closed mid-capture, the
#                   offline session view, the HTML reports with the network off, bad
#                   input, read-only server; then test-view-lint
#   view-figures    the screenshots of docs/view.md (docs/figures/view-*.png), made by
#                   the same tests
#   bench-view      the server's CPU at a 1 kHz device stream and the page's update
#                   latency, JSON lines

VIEW_PY_FILES := host/src/aacmm/view host/src/aacmm/commands/view.py \
                 tests/host/test_view.py tests/host/viewbrowser.py bench/bench_view.py
VIEW_PYTEST   := $(PYTHON) -m pytest -q -p no:cacheprovider -ra -c host/pyproject.toml --rootdir=.

.PHONY: test-view test-view-lint view-figures bench-view

#> test-view            the live view, capture --view, offline views and HTML reports in headless Chromium
test-view: sim
	$(VIEW_PYTEST) tests/host/test_view.py
	@$(MAKE) --no-print-directory test-view-lint

#> test-view-lint       ruff, ruff format, mypy --strict on aacmm.view and its tests (part of test-view)
test-view-lint:
	$(call py_lint,$(VIEW_PY_FILES))

#> view-figures         regenerate the screenshots of docs/view.md (docs/figures/view-*.png)
view-figures: sim
	AACMM_VIEW_FIGURES=docs/figures $(VIEW_PYTEST) tests/host/test_view.py \
	    -k "live_view_two_pages or capture_view or offline_session or reports_open"

TEST_SUITES += test-view
TEST_ALONE  += test-view

bench-view: sim
	@$(PYTHON) bench/bench_view.py
BENCH_TARGETS += bench-view
