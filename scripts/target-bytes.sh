#!/usr/bin/env bash
# The bytes table: `.text` of the Cortex-M4F firmware and the size of the WASM module (scalar and
# simd128), both `opt-level = "z"` with LTO, for each variant of what they name at compile time —
# the primitive kinds (the traversal kernel) and the camera. Each firmware variant also runs its
# scene under QEMU against the host's render (targets/cortex-m4f/run.sh). Prints a Markdown table;
# with --update, also writes it into README.md and targets/cortex-m4f/README.md between the
# markers <!-- target-bytes:begin --> and <!-- target-bytes:end -->.
# Usage: scripts/target-bytes.sh [--update]   (CARGO_TARGET_DIR respected; takes a few minutes)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
base="${CARGO_TARGET_DIR:-$root/target}"
command -v readelf >/dev/null || { apt-get update -qq && apt-get install -y -qq binutils >/dev/null; }

# name | scene | features
variants=(
  "triangles, pinhole|targets/cortex-m4f/scenes/triangles.toml|triangles pinhole"
  "spheres, pinhole|targets/cortex-m4f/scenes/spheres.toml|spheres pinhole"
  "triangles + spheres, pinhole|host/scenes/default.toml|mixed pinhole"
  "everything: triangles + spheres, every camera|host/scenes/default.toml|mixed any-camera"
)

elf="$base/targets/cortex-m4f/thumbv7em-none-eabihf/release/kdray-cortex-m4f"
table=$(mktemp)
trap 'rm -f "$table"' EXIT
{
echo "| variant (cargo features) | firmware .text | .wasm scalar | .wasm simd128 | firmware = host |"
echo "|---|---:|---:|---:|---|"
for v in "${variants[@]}"; do
  IFS='|' read -r name scene features <<<"$v"
  line=$(KDRAY_FW_FEATURES="$features" "$root/targets/cortex-m4f/run.sh" "$root/$scene" 2>/dev/null) || true
  match=$(sed -n 's/.*match=\([a-z]*\).*/\1/p' <<<"$line")
  # The size column of the section header line: "[Nr] Name Type Address Off Size ..."
  text=$((16#$(readelf -SW "$elf" | awk '{ for (i = 1; i < NF; i++) if ($i == ".text") print $(i + 4) }')))
  out="$base/targets/wasm-bytes/${features// /-}"
  KDRAY_WASM_OUT="$out" CARGO_TARGET_DIR="$base/targets" "$root/targets/wasm/build.sh" \
    --no-default-features --features "$features" >/dev/null
  scalar=$(stat -c %s "$out/kdray_wasm_scalar.wasm")
  simd=$(stat -c %s "$out/kdray_wasm_simd128.wasm")
  printf '| %s (`%s`) | %s | %s | %s | %s |\n' "$name" "$features" "$text" "$scalar" "$simd" "${match:-no}"
done
} | tee "$table"

if [[ "${1:-}" == "--update" ]]; then
  for readme in "$root/README.md" "$root/targets/cortex-m4f/README.md"; do
    awk -v table="$table" '
      /<!-- target-bytes:end -->/ { skip = 0 }
      !skip { print }
      /<!-- target-bytes:begin -->/ { while ((getline line < table) > 0) print line; skip = 1 }
    ' "$readme" >"$readme.new"
    mv "$readme.new" "$readme"
  done
fi
