#!/usr/bin/env bash
# Every GPU measurement the README reports, in one run, on whatever wgpu
# adapter the machine has (issue 35):
#   bench/gpu.sh OUT_DIR [--quick]
# - foveated against full resolution at 1080p and 4K for the shipped
#   scenes that render on the GPU (`bench stages --backend gpu`): frame
#   times, the GPU's per-pass timestamps, the bytes uploaded and read back,
#   dispatches and submits per frame (p50 and max, counted at the wgpu
#   calls), and the headless frame loop's rate (a new mask every frame, and
#   a kept mask);
# - each method's frame time with its passes and its traffic
#   (`render --backend gpu --repeat N --stats`);
# and writes OUT_DIR/gpu.md (Markdown tables, the adapter at the top) and
# OUT_DIR/gpu.json (every figure), beside the raw outputs.
#
# --quick: tiny displays (128×72 and 256×144 pixels on the 1080p and 4K
# monitors' sizes), two scenes, three methods, 2 frames each: about 30–60 s
# on lavapipe with a debug binary (the viewer's tests run it so).
# GAZECAST_BIN=path: use that binary instead of building target/release.
# Without a GPU adapter (not even lavapipe) it says so and exits 2.
# On the lent GPU machine (no Vulkan loader installed): unpack the loader's
# .deb files from .gl/ first (as root), and point VK_DRIVER_FILES at the
# NVIDIA ICD when no driver is found; both are done here when they apply.
# Needs bash, awk and python3 (no jq).
set -euo pipefail
usage() { echo "usage: bench/gpu.sh OUT_DIR [--quick]" >&2; exit 64; }
[ $# -ge 1 ] && [ $# -le 2 ] || usage
out=$1
quick=0
if [ $# -eq 2 ]; then
  [ "$2" = --quick ] || usage
  quick=1
fi
root=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
out=$(cd "$out" && pwd)
cd "$root"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
started=$(date +%s)

# The Vulkan loader: a machine without one (the lent GPU machine) gets it
# from .gl/*.deb (apt-get download libvulkan1 …), unpacked as root.
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; then
  if compgen -G ".gl/*.deb" >/dev/null && [ "$(id -u)" = 0 ]; then
    echo "gpu.sh: no Vulkan loader; unpacking .gl/*.deb" >&2
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
fi
# The NVIDIA driver's ICD where the loader does not find it by itself.
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$nvidia_icd" ]; then
  export VK_DRIVER_FILES=$nvidia_icd
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
fi

if [ -n "${GAZECAST_BIN:-}" ]; then
  bin=$GAZECAST_BIN
else
  echo "gpu.sh: building the release binary" >&2
  cargo build --release --quiet --bin gazecast
  bin=$root/target/release/gazecast
fi
[ -x "$bin" ] || { echo "gpu.sh: $bin is not an executable" >&2; exit 64; }

raw=$out/raw
mkdir -p "$raw"
rm -f "$raw"/*.json "$raw"/*.md "$raw"/*.err "$raw"/*.png
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if [ $quick = 1 ]; then
  # Two small displays of the 1080p and 4K monitors' physical size.
  printf 'Display(name: "quick 1080p-sized", resolution_px: (128, 72), size_mm: (531.4, 298.9), eye_distance_mm: 600.0)\n' >"$tmp/small.ron"
  printf 'Display(name: "quick 4K-sized", resolution_px: (256, 144), size_mm: (596.7, 335.7), eye_distance_mm: 600.0)\n' >"$tmp/large.ron"
  # The search task on both, the depth-of-field scene (GPU passes) on the
  # small one: each job is SCENES|DISPLAYS for one `bench stages`.
  jobs=("config/scenes/search-task.ron|$tmp/small.ron,$tmp/large.ron"
        "config/scenes/stress-dof.ron|$tmp/small.ron")
  method_scene=config/scenes/search-task.ron
  method_displays="$tmp/small.ron"
  methods="full hybrid image"
  repeats=2
else
  # moving.ron uploads each frame's pose (its BVH rebuilt on the CPU).
  jobs=("config/scenes/search-task.ron,config/scenes/bunny.ron,config/scenes/faces.ron,config/scenes/stress.ron,config/scenes/stress-dof.ron,config/scenes/room.ron,config/scenes/moving.ron|config/displays/desktop-24in-1080p.ron,config/displays/desktop-27in-4k.ron")
  method_scene=config/scenes/stress-dof.ron
  method_displays="config/displays/desktop-24in-1080p.ron config/displays/desktop-27in-4k.ron"
  # ulod renders on the CPU only (its attention and levels are CPU code).
  methods="full hybrid image simplify lod layers"
  repeats=10
fi

# The adapter: one tiny GPU frame, or a clear failure.
printf 'Display(name: "probe", resolution_px: (64, 48), size_mm: (100.0, 75.0), eye_distance_mm: 600.0)\n' >"$tmp/probe.ron"
if ! "$bin" render --scene config/scenes/search-task.ron --display "$tmp/probe.ron" \
  --backend gpu --out "$tmp/probe.png" --stats "$raw/probe.json" >"$tmp/probe.out" 2>"$raw/probe.err"; then
  echo "gpu.sh: no GPU adapter could render (not even a software one such as Mesa's lavapipe):" >&2
  cat "$raw/probe.err" >&2
  echo "gpu.sh: install a Vulkan driver (Debian: mesa-vulkan-drivers for lavapipe) or, on the lent GPU machine, the loader from .gl/ (see bench/gpu.sh's header)" >&2
  exit 2
fi
adapter=$(grep -o '"adapter": "[^"]*"' "$raw/probe.json" | head -1 | sed 's/^"adapter": "//; s/"$//')
echo "gpu.sh: adapter: $adapter" >&2
case "$adapter" in
  *", Cpu,"*) echo "gpu.sh: a CPU adapter (software rendering): its times say nothing about a GPU's speed; bytes and dispatches are exact" >&2 ;;
esac

k=0
for job in "${jobs[@]}"; do
  scenes=${job%%|*}
  displays=${job#*|}
  k=$((k + 1))
  echo "gpu.sh: bench stages --backend gpu ($scenes; $displays; $repeats repeats)" >&2
  "$bin" bench stages --backend gpu --scene "$scenes" --display "$displays" --repeats "$repeats" \
    --json "$raw/stages-$k.json" >"$raw/stages-$k.md"
done

status=0
for d in $method_displays; do
  for m in $methods; do
    name=$(basename "$d" .ron)-$m
    echo "gpu.sh: render --method $m --backend gpu ($method_scene, $(basename "$d"))" >&2
    if ! "$bin" render --scene "$method_scene" --display "$d" --method "$m" --backend gpu \
      --repeat "$repeats" --out "$tmp/$name.png" --stats "$raw/method-$name.json" \
      >"$tmp/$name.out" 2>"$raw/method-$name.err"; then
      echo "gpu.sh: method $m failed on the GPU backend: $(tail -1 "$raw/method-$name.err")" >&2
      status=1
    fi
  done
done

elapsed=$(( $(date +%s) - started ))
python3 - "$out" "$raw" "$quick" "$elapsed" "$adapter" <<'PY'
import glob, json, os, sys

out, raw, quick, elapsed, adapter = sys.argv[1], sys.argv[2], sys.argv[3] == "1", int(sys.argv[4]), sys.argv[5]
software = ", Cpu," in adapter
stages = None
for path in sorted(glob.glob(os.path.join(raw, "stages-*.json"))):
    part = json.load(open(path))
    if stages is None:
        stages = part
    else:
        stages["rows"].extend(part["rows"])
methods = []
for path in sorted(glob.glob(os.path.join(raw, "method-*.json"))):
    r = json.load(open(path))
    methods.append(r)
failed = []
for path in sorted(glob.glob(os.path.join(raw, "method-*.err"))):
    name = os.path.basename(path)[len("method-"):-len(".err")]
    if not os.path.exists(os.path.join(raw, f"method-{name}.json")):
        lines = [l for l in open(path).read().splitlines() if l.strip()]
        failed.append({"run": name, "error": lines[-1] if lines else "failed"})

note = ("The adapter is a CPU implementation (Mesa's lavapipe/llvmpipe): "
        "its times say nothing about a GPU's speed. The bytes, dispatches and "
        "submits are exact on any adapter.") if software else (
        "Times from a real GPU: the frame times are wall clock through the "
        "read-back, the per-pass times the adapter's timestamp queries.")
doc = {
    "adapter": adapter,
    "software_adapter": software,
    "quick": quick,
    "note": note,
    "run_seconds": elapsed,
    "stages": stages,
    "methods": methods,
    "failed": failed,
}
with open(os.path.join(out, "gpu.json"), "w") as f:
    json.dump(doc, f, indent=2)
    f.write("\n")

def fmt(v, p=1):
    return "n/a" if v is None else f"{v:.{p}f}"

L = []
L.append("# gazecast on the GPU (bench/gpu.sh%s)" % (" --quick" if quick else ""))
L.append("")
L.append(f"Adapter: **{adapter}**")
L.append("")
if software:
    L.append("**A CPU adapter (lavapipe/llvmpipe): these times say nothing about a GPU's speed.** "
             "Bytes, dispatches and submits are exact on any adapter.")
else:
    L.append(note)
L.append("")
L.append(f"{stages['repeats']} timed frames per figure (medians); run time {elapsed} s.")
L.append("")
L.append("## Foveated against full resolution (`bench stages --backend gpu`)")
L.append("")
L.append("| scene | display | full ms | foveated ms | full / foveated | loop fps, new mask | loop fps, kept mask |")
L.append("|---|---|---:|---:|---:|---:|---:|")
for r in stages["rows"]:
    L.append(f"| {r['scene']} | {r['width_px']}x{r['height_px']} | {fmt(r['full_ms'])} | {fmt(r['foveated_ms'])} | "
             f"{fmt(r['full_over_foveated'], 2)} | {fmt(r['loop_fps_new_mask'])} | {fmt(r['loop_fps_kept_mask'])} |")
L.append("")
names = []
for r in stages["rows"]:
    for s in r["foveated_stages_ms"]:
        if s["pass"] not in names:
            names.append(s["pass"])
if names:
    L.append("## Per-pass GPU time of the foveated frame (timestamp queries, ms, median)")
    L.append("")
    L.append("| scene | display | " + " | ".join(names) + " | full frame's pass |")
    L.append("|---|---|" + "---:|" * (len(names) + 1))
    for r in stages["rows"]:
        by = {s["pass"]: s["ms"] for s in r["foveated_stages_ms"]}
        full = sum(s["ms"] for s in r["full_stages_ms"]) if r["full_stages_ms"] else None
        L.append(f"| {r['scene']} | {r['width_px']}x{r['height_px']} | " +
                 " | ".join(fmt(by.get(n), 2) for n in names) + f" | {fmt(full, 2)} |")
    L.append("")
else:
    L.append("The adapter has no timestamp queries: no per-pass times.")
    L.append("")
L.append("## Bytes and calls per frame between the CPU and the GPU (counted at the wgpu calls; p50 / max)")
L.append("")
L.append("| scene | display | frame | frames | uploaded B | read back B | dispatches | submits |")
L.append("|---|---|---|---:|---:|---:|---:|---:|")
for r in stages["rows"]:
    for t in r["traffic"]:
        pm = lambda k: f"{t[k]['p50']} / {t[k]['max']}"
        L.append(f"| {r['scene']} | {r['width_px']}x{r['height_px']} | {t['frame']} | {t['frames']} | "
                 f"{pm('uploaded_bytes')} | {pm('read_back_bytes')} | {pm('dispatches')} | {pm('submits')} |")
L.append("")
L.append("## Each method on the GPU backend (`render --backend gpu --repeat N --stats`)")
L.append("")
L.append("| method | scene | display | frame ms (median) | GPU passes (ms) | uploaded B | read back B | dispatches | draws | submits |")
L.append("|---|---|---|---:|---|---:|---:|---:|---:|---:|")
for r in methods:
    t = r.get("gpu_traffic") or {}
    passes = ", ".join(f"{s['stage']} {s['ms']:.2f}" for s in r.get("gpu_stages_ms", [])) or "n/a"
    L.append(f"| {r['mode']} | {r['scene']} | {r['width_px']}x{r['height_px']} | {fmt(r['time_ms'])} | {passes} | "
             f"{t.get('uploaded_bytes', 'n/a')} | {t.get('read_back_bytes', 'n/a')} | {t.get('dispatches', 'n/a')} | "
             f"{t.get('draws', 'n/a')} | {t.get('submits', 'n/a')} |")
for f in failed:
    L.append(f"| {f['run']} | | | failed | {f['error']} | | | | | |")
L.append("")
L.append("Traffic of a method's row: its last frame (the same gaze every repeat).")
with open(os.path.join(out, "gpu.md"), "w") as f:
    f.write("\n".join(L) + "\n")
PY
echo "gpu.sh: wrote $out/gpu.md and $out/gpu.json in ${elapsed} s" >&2
exit $status
