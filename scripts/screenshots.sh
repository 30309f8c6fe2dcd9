#!/usr/bin/env bash
# Runs every example for a few seconds under Xvfb with software Vulkan (llvmpipe) and saves a
# PNG of each in assets/screenshots/. Installs what it needs (Debian/Ubuntu, needs root or sudo).
#
#   bash scripts/screenshots.sh            # all examples
#   bash scripts/screenshots.sh cloth      # one
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/bevy_verlet_physics/target}"
PROFILE="${PROFILE:-release}"

need=()
command -v xvfb-run >/dev/null || need+=(xvfb)
command -v xauth >/dev/null || need+=(xauth)
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || need+=(mesa-vulkan-drivers)
if ((${#need[@]})); then
    sudo=""
    [ "$(id -u)" = 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    $sudo apt-get install -y "${need[@]}"
fi

examples=("$@")
[ ${#examples[@]} -gt 0 ] || examples=(cloth ragdoll structures shapes lanterns cloth_3d avian_2d avian_3d)
# Frames before the screenshot, per example (llvmpipe draws ~30 frames/s).
declare -A frames=([cloth]=150 [ragdoll]=85 [structures]=150 [shapes]=150 [lanterns]=150 [cloth_3d]=150 [avian_2d]=120 [avian_3d]=120)

flag=()
[ "$PROFILE" = release ] && flag=(--release)
cargo build "${flag[@]}" --features examples,avian2d,avian3d $(printf -- '--example %s ' "${examples[@]}")

mkdir -p assets/screenshots
for name in "${examples[@]}"; do
    out="$PWD/assets/screenshots/$name.png"
    rm -f "$out"
    echo "== $name → $out"
    VERLET_SCREENSHOT="$out" VERLET_SCREENSHOT_FRAMES="${FRAMES:-${frames[$name]:-150}}" \
        timeout 300 xvfb-run -a -s "-screen 0 1280x720x24" \
        "$CARGO_TARGET_DIR/$PROFILE/examples/$name" || true
    [ -s "$out" ] || { echo "no screenshot for $name" >&2; exit 1; }
done
