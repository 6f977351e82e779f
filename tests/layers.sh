#!/bin/sh
# The layers of docs/architecture.md, checked. src/ holds one folder per
# layer, lowest first in LAYERS; a source's layer is its folder, a public
# header's (include/dm_NAME.h) the folder of src/*/NAME.c, or HEADER_ONLY's
# entry for a header with no source. Every file must have a layer, and no
# file may include a header of a layer above its own (headers and sources
# alike; a private header, such as src/maps/sweep_impl.h, only from its own
# folder). Run by the build before the library is archived and by `make
# test`; exits 1 naming each offending file or include.
cd "$(dirname "$0")/.." || exit 2
LAYERS="base robot model solve responses maps measure cli"
HEADER_ONLY="vec3:base version:base progress:base"

rank() { # index of layer $1 in LAYERS, empty if none
    i=0
    for l in $LAYERS; do
        [ "$l" = "$1" ] && { echo $i; return; }
        i=$((i + 1))
    done
}

# Layer of module $1 (a header's name without dm_ and .h).
module_layer() {
    for e in $HEADER_ONLY; do
        [ "${e%%:*}" = "$1" ] && { echo "${e#*:}"; return; }
    done
    for f in src/*/"$1".c; do
        [ -f "$f" ] && { basename "$(dirname "$f")"; return; }
    done
}

bad=0
for f in src/* src/*/*; do
    [ -d "$f" ] && [ -z "$(rank "$(basename "$f")")" ] && {
        echo "layers: $f: a folder that is no layer (LAYERS in tests/layers.sh)"
        bad=1
    }
done
for f in src/*.[ch]; do
    [ -f "$f" ] && { echo "layers: $f: outside the layer folders"; bad=1; }
done
for f in src/*/*.[ch] include/dm_*.h; do
    case $f in
    include/*) name=$(basename "$f" .h); own=$(module_layer "${name#dm_}") ;;
    *) own=$(basename "$(dirname "$f")") ;;
    esac
    r=$(rank "$own")
    if [ -z "$r" ]; then
        echo "layers: $f: no layer (a public header needs src/LAYER/NAME.c or an entry in HEADER_ONLY)"
        bad=1
        continue
    fi
    for inc in $(sed -n 's/^#include "\([a-z_0-9]*\)\.h".*/\1/p' "$f"); do
        case $inc in
        dm_*) l=$(module_layer "${inc#dm_}") ;;
        *) # a private header: beside the file that includes it
            if [ -f "$(dirname "$f")/$inc.h" ] && [ "${f#include/}" = "$f" ]; then
                l=$own
            else
                echo "layers: $f includes $inc.h, a private header of another folder"
                bad=1
                continue
            fi ;;
        esac
        lr=$(rank "$l")
        if [ -z "$lr" ]; then
            echo "layers: $f includes $inc.h, a module with no layer"
            bad=1
        elif [ "$lr" -gt "$r" ]; then
            echo "layers: $f (layer $own) includes $inc.h of layer $l above it"
            bad=1
        fi
    done
done
[ $bad -eq 0 ] && echo "layers: every include goes down or across"
exit $bad
