#!/bin/sh
# docs/cli.md is what tools/cli_doc.sh makes of this binary's --help texts:
# the command reference cannot drift from the code. Exits 1 with the diff.
cd "$(dirname "$0")/.." || exit 2
DM=${DELTAMAP:-build/deltamap}
TMP=$(mktemp)
trap 'rm -f "$TMP"' EXIT
tools/cli_doc.sh "$DM" >"$TMP" || { echo "FAIL: tools/cli_doc.sh"; exit 1; }
n=$(grep -c '^## deltamap ' "$TMP")
if [ "$n" -lt 12 ]; then echo "FAIL: cli doc: only $n commands found in --help"; exit 1; fi
if diff -u docs/cli.md "$TMP"; then
    echo "cli doc: docs/cli.md matches --help of $n commands"
else
    echo "FAIL: docs/cli.md differs from --help (run: tools/cli_doc.sh > docs/cli.md)"
    exit 1
fi
