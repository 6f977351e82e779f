#!/bin/sh
# The layers of docs/architecture.md, checked: every module has a layer,
# and no file includes a header of a layer above its own (headers and
# sources alike). Run by `make test`; exits 1 naming each offending include.
cd "$(dirname "$0")/.." || exit 2
layer_of() {
    case $1 in
    error | vec3 | threads | file | csv | version) echo 0 ;;
    robot | kinematics) echo 1 ;;
    beam | arrow | model | loads) echo 2 ;;
    static | modal | analysis | coupling) echo 3 ;;
    trajectory | integrate | integrate_trajectory | standard_move | budget | tolerance) echo 4 ;;
    grid | shard | store | sweep | sweep_schema | sweep_store | sweep_anchors | sweep_census | sweep_impl) echo 5 ;;
    measure | diagnose | plan) echo 6 ;;
    cli | cli_* | main) echo 7 ;;
    *) echo "" ;;
    esac
}
bad=0
for f in src/*.c src/*.h include/dm_*.h; do
    name=$(basename "$f"); name=${name%.*}; name=${name#dm_}
    own=$(layer_of "$name")
    if [ -z "$own" ]; then
        echo "layers: $f: module '$name' has no layer (add it to tests/layers.sh and docs/architecture.md)"
        bad=1
        continue
    fi
    for inc in $(sed -n 's/^#include "\([a-z_0-9]*\)\.h".*/\1/p' "$f"); do
        dep=${inc#dm_}
        l=$(layer_of "$dep")
        if [ -z "$l" ]; then
            echo "layers: $f includes $inc.h, a module with no layer"
            bad=1
        elif [ "$l" -gt "$own" ]; then
            echo "layers: $f (layer $own) includes $inc.h of layer $l above it"
            bad=1
        fi
    done
done
[ $bad -eq 0 ] && echo "layers: every include goes down or across"
exit $bad
