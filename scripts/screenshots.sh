#!/usr/bin/env bash
# Renders every example under a virtual X server with Mesa's software Vulkan
# (lavapipe) and saves the pictures the README shows, in docs/.
#
#   scripts/screenshots.sh            # release build, all examples
#   PROFILE=test BUILD=0 OUT=target/shots scripts/screenshots.sh terrain
#                                     # run what `cargo test --workspace` built (CI)
#
# Builds use --workspace so features unify exactly as in `cargo test --workspace`
# (building one package alone resolves some shared crates' features differently
# and rebuilds Bevy).
#
# Each example exits non-zero if its picture is one flat colour or it errors.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=${PROFILE:-release}
build=${BUILD:-1}
out_dir=${OUT:-docs}
mkdir -p "$out_dir"
examples=("$@")
[ ${#examples[@]} -eq 0 ] && examples=(terrain csg_editor lod compare volume)

if ! command -v xvfb-run >/dev/null || ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
    echo "== installing Xvfb and Mesa's software Vulkan"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1 xvfb xauth
fi

dir=target/$([ "$profile" = dev ] || [ "$profile" = test ] && echo debug || echo "$profile")
for ex in "${examples[@]}"; do
    if [ "$build" != 0 ]; then
        # The inspector example needs its feature (a second build of Bevy's
        # render crates with the inspector's features; not in the default list).
        features=()
        [ "$ex" = inspector ] && features=(--features bevy_kdcontour/inspector)
        cargo build -q --profile "$profile" --workspace --example "$ex" "${features[@]}"
    fi
    test -x "$dir/examples/$ex" || { echo "error: $dir/examples/$ex is not built"; exit 1; }
    out=$out_dir/$ex.png
    extra=()
    # The editor loads a scene file if one exists; render the built-in one.
    [ "$ex" = csg_editor ] && extra=(--scene target/screenshot_scene.json) && rm -f target/screenshot_scene.json
    echo "== $ex -> $out"
    start=$(date +%s)
    timeout 1200 xvfb-run -a -s "-screen 0 1280x720x24" "$dir/examples/$ex" "${extra[@]}" --screenshot "$out" --frames 20
    echo "   $(( $(date +%s) - start )) s"
    test -s "$out"
done
