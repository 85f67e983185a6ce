#!/bin/sh
# `make check-format`: every tracked Python file as `ruff format` writes it,
# and plain-text hygiene in the sources: LF line ends, no trailing blanks, a
# final newline, and no tab characters in C, headers and Python. Prints the
# offending files; exit status 1 if there are any.
# Usage: check-format.sh RUFF PYPROJECT
set -u
ruff=$1 config=$2
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    files() { git ls-files -- "$@"; }
else
    files() { for p in "$@"; do find . -path ./.venv -prune -o -path ./build -prune -o -name "$p" -type f -print; done | sed 's|^\./||'; }
fi
bad=0
py=$(files '*.py')
# shellcheck disable=SC2086
"$ruff" format --config "$config" --check $py || bad=1
for f in $(files '*.c' '*.h' '*.py' '*.md' '*.mk' '*.sh' '*.toml' '*.ld' Makefile); do
    [ -f "$f" ] || continue
    if grep -q "$(printf '\r')" "$f"; then echo "$f: CR line ends"; bad=1; fi
    if grep -nq '[[:blank:]]$' "$f"; then
        echo "$f:$(grep -n '[[:blank:]]$' "$f" | head -1 | cut -d: -f1): trailing blanks"; bad=1
    fi
    if [ -s "$f" ] && [ "$(tail -c 1 "$f" | od -An -tx1 | tr -d ' ')" != "0a" ]; then
        echo "$f: no newline at the end"; bad=1
    fi
    case $f in
    *.c | *.h | *.py)
        if grep -q "$(printf '\t')" "$f"; then echo "$f: tab characters"; bad=1; fi ;;
    esac
done
[ "$bad" -eq 0 ] && echo "check-format: all sources formatted"
exit "$bad"
