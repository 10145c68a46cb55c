#!/usr/bin/env python3
"""raylab against Mitsuba 3 on the same scene, side by side, in one run.

Run through `scripts/bench-peers` (or `make bench-peers`), which installs
Mitsuba 3 and Dr.Jit into .deps/peers-venv and runs this file with that
venv's Python. What it does:

1. Reads the raylab scene file (TOML) itself and builds the same scene for
   Mitsuba: every triangle (one PLY per material, written to a temporary
   folder), a two-sided `diffuse` BSDF of the albedo raylab's path tracer
   uses, the emissive triangles as `area` emitters, the pinhole camera, the
   film and its filter, the `path` integrator at the matching depth with
   Russian roulette off. The equivalences are spelled out in `convert()`.
2. Times, on the same machine and thread count, raylab's command
   (`raylab render SCENE --integrator path:K --sampler random:SPP --accel bvh
   --width W --height H --rr-depth off --threads T`, wall clock from process
   start to end, plus the render time raylab prints) and Mitsuba's variants
   (`scalar_rgb`, `llvm_ad_rgb`, and `llvm_ad_rgb@avx2`, the LLVM variant
   held to AVX2's 8 lanes, raylab's SIMD width, where Dr.Jit would use
   AVX-512's 16: one warm-up render, which for LLVM includes compiling the
   kernels into an empty kernel cache, then timed renders).
   The timed runs go round-robin (raylab, scalar, LLVM, LLVM at AVX2,
   raylab, ...) so that a change in the machine's load hits every tool
   alike; the table gives the median of each.
3. Compares the images: the mean RGB of raylab's EXR against the mean of
   Mitsuba's renders (per channel, whole image and halves: a mirrored camera
   or a missing wall shows there), with the Monte Carlo standard error of
   the difference. A difference above --tolerance means the two scenes are
   not the same, and the script exits with status 3.

With --out DIR it writes DIR/bench-peers.json (every run, the machine, the
versions, the commands, the comparison) and DIR/bench-peers.csv (one row per
run).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import re
import resource
import shutil
import statistics
import struct
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PROTOCOL = "@@bench-peers "
# Mitsuba's emitter-sampling weight of the reversed copies of emitting
# triangles (the front copies have 1); see `convert`.
BACK_SAMPLING_WEIGHT = 0.01


def die(msg: str, code: int = 1) -> None:
    print(f"bench-peers: error: {msg}", file=sys.stderr)
    sys.exit(code)


# --------------------------------------------------------------------------
# The scene: raylab's TOML → a plain description Mitsuba's loader can take
# --------------------------------------------------------------------------


def rotation_xyz_degrees(deg):
    """raylab's `M3::rotation_xyz_degrees`: Rz·Ry·Rx (about x first)."""
    ax, ay, az = (math.radians(d) for d in deg)
    sx, cx = math.sin(ax), math.cos(ax)
    sy, cy = math.sin(ay), math.cos(ay)
    sz, cz = math.sin(az), math.cos(az)
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rz = [[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]
    return matmul(matmul(rz, ry), rx)


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def read_obj(path: Path):
    """Positions and triangles (fans) of an OBJ file; raises on normals
    (raylab would shade with them, this converter only does flat)."""
    pos, tris = [], []
    for line in path.read_text().splitlines():
        f = line.split()
        if not f:
            continue
        if f[0] == "v":
            pos.append([float(x) for x in f[1:4]])
        elif f[0] == "vn":
            raise ValueError(f"{path}: has vertex normals; only flat-shaded meshes are converted")
        elif f[0] == "f":
            idx = []
            for tok in f[1:]:
                i = int(tok.split("/")[0])
                idx.append(i - 1 if i > 0 else len(pos) + i)
            for k in range(1, len(idx) - 1):
                tris.append((idx[0], idx[k], idx[k + 1]))
    return pos, tris


def mesh_triangles(m: dict, scene_dir: Path):
    """The world-space triangles of a `[[mesh]]`, transformed as raylab's
    `io::scene_file::mesh_affine` does: x' = R·S·(x − centre)·fit + T."""
    if "file" not in m:
        raise ValueError("procedural meshes are not converted")
    path = scene_dir / m["file"]
    if path.suffix.lower() != ".obj":
        raise ValueError(f"{path}: only .obj meshes are converted")
    if m.get("normals", "file") not in ("file", "flat"):
        raise ValueError(f"{path}: normals = {m['normals']!r} is not converted (flat only)")
    pos, tris = read_obj(path)
    scale = m.get("scale", 1.0)
    scale = [float(scale)] * 3 if isinstance(scale, (int, float)) else [float(s) for s in scale]
    centre, fit_scale = [0.0, 0.0, 0.0], 1.0
    if "fit" in m:
        lo = [min(p[i] for p in pos) for i in range(3)]
        hi = [max(p[i] for p in pos) for i in range(3)]
        fit_scale = float(m["fit"]) / max(hi[i] - lo[i] for i in range(3))
        centre = [0.5 * (lo[i] + hi[i]) for i in range(3)]
    s = [x * fit_scale for x in scale]
    r = rotation_xyz_degrees(m.get("rotate", [0.0, 0.0, 0.0]))
    lin = [[r[i][j] * s[j] for j in range(3)] for i in range(3)]
    t = m.get("translate", [0.0, 0.0, 0.0])
    world = [
        [sum(lin[i][j] * (p[j] - centre[j]) for j in range(3)) + t[i] for i in range(3)] for p in pos
    ]
    return [[world[a], world[b], world[c]] for a, b, c in tris]


def write_ply(path: Path, triangles) -> None:
    """Binary PLY, three vertices of its own per triangle (flat shading)."""
    n = len(triangles)
    head = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {3 * n}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {n}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with path.open("wb") as f:
        f.write(head.encode("ascii"))
        for tri in triangles:
            for v in tri:
                f.write(struct.pack("<3f", *v))
        for k in range(n):
            f.write(struct.pack("<B3i", 3, 3 * k, 3 * k + 1, 3 * k + 2))


def convert(scene_path: Path, args, workdir: Path) -> tuple[dict, list[str]]:
    """The scene as a JSON-able description (`spec`) from which a worker
    builds the Mitsuba dict, and notes on what was matched and how."""
    doc = tomllib.loads(scene_path.read_text())
    notes: list[str] = []
    for kind in ("sphere", "ellipsoid", "plane"):
        if doc.get(kind):
            raise ValueError(f"[[{kind}]] is not converted (triangles and OBJ meshes only)")
    render = doc.get("render", {})
    if any(c != 0 for c in render.get("background", [0, 0, 0])):
        raise ValueError("a non-black background is not converted")
    if float(render.get("max_distance", 1e30)) < 1e30:
        raise ValueError("a finite max_distance is not converted")
    # raylab's film filter for `random:N` is the scene's `filter` (no
    # --filter is passed): `box` = the mean of the pixel's own samples, i.e.
    # Mitsuba's `box` filter (radius ½ pixel). tent (radius 1) and Mitchell
    # (B = C = ⅓, radius 2) are Mitsuba's `tent` and `mitchell`.
    rfilter = render.get("filter", "box")
    if rfilter not in ("box", "tent", "mitchell"):
        raise ValueError(f"unknown filter {rfilter!r}")

    # Materials. raylab's path tracer (crates/core/src/integrator/path.rs) makes every
    # surface Lambertian with albedo ρ = clamp(k_d × color, 0, 1)
    # (`MaterialR::lambert_albedo`), two-sided (hits' normals are turned to
    # face the ray, `Scene::hit_details`); specular, mirror and glass terms
    # are ignored. So: Mitsuba `twosided` `diffuse` of reflectance ρ.
    mats = {}
    for name, m in doc.get("materials", {}).items():
        if "texture" in m:
            raise ValueError(f"material {name!r}: textures are not converted")
        color = m.get("color", [0.8, 0.8, 0.8])
        kd = float(m.get("diffuse", 0.9))
        albedo = [min(1.0, max(0.0, kd * c)) for c in color]
        mats[name] = {"albedo": albedo, "emission": list(m.get("emission", [0.0, 0.0, 0.0]))}
        notes.append(f"material {name}: albedo = diffuse {kd:g} × color {color} = "
                     f"[{', '.join(f'{a:.4g}' for a in albedo)}]")

    tris: dict[str, list] = {}
    for t in doc.get("triangle", []):
        tris.setdefault(t["material"], []).append(t["vertices"])
    for m in doc.get("mesh", []):
        tris.setdefault(m["material"], []).extend(mesh_triangles(m, scene_path.parent))
    shapes = []
    for name, tl in tris.items():
        if name not in mats:
            raise ValueError(f"unknown material {name!r}")
        ply = workdir / f"{name}.ply"
        write_ply(ply, tl)
        shapes.append({"name": name, "ply": str(ply), "albedo": mats[name]["albedo"],
                       "emission": mats[name]["emission"], "triangles": len(tl)})
        if any(e > 0 for e in mats[name]["emission"]) and not args.one_sided_light:
            # raylab's emission is two-sided (`lambert_area_sample` takes
            # |cos θ_l|, `brdf_hit_weight` any side); Mitsuba's area lights
            # emit on their front only. So each emitting triangle gets a
            # reversed copy 1e-4 behind it: a ray from either side meets the
            # copy facing it first. (In the Cornell box the light's back
            # faces the ceiling 2 mm away, yet the light it sends into that
            # gap and out of it is ~1 % of the image's mean.) One light
            # sample of raylab's serves both sides; Mitsuba picks an emitter
            # first, so the copies get a small sampling weight: its light
            # samples (and shadow rays) go to the side the scene below sees,
            # as raylab's do, and the gap is lit through BRDF sampling
            # (MIS keeps both estimators unbiased).
            back = []
            for a, b, c in tl:
                n = cross(sub(b, a), sub(c, a))
                ln = math.sqrt(sum(x * x for x in n))
                off = [-1e-4 * x / ln for x in n]
                back.append([add(a, off), add(c, off), add(b, off)])
            ply = workdir / f"{name}-back.ply"
            write_ply(ply, back)
            shapes.append({"name": f"{name}-back", "ply": str(ply), "albedo": mats[name]["albedo"],
                           "emission": mats[name]["emission"], "triangles": len(back),
                           "sampling_weight": BACK_SAMPLING_WEIGHT, "copy": True})
    n_tri = sum(s["triangles"] for s in shapes if not s.get("copy"))
    n_copies = sum(s["triangles"] for s in shapes if s.get("copy"))
    emitters = [s for s in shapes if any(e > 0 for e in s["emission"])]
    if args.one_sided_light:
        notes.append(
            "emitters: one-sided in Mitsuba (--one-sided-light: front = counter-clockwise side) "
            "while raylab's are two-sided: expect Mitsuba's image ~1 % darker")
    else:
        notes.append(
            "emitters: raylab's are two-sided, Mitsuba's area lights one-sided: each emitting "
            f"triangle also has a reversed copy 1e-4 behind it (emitter sampling weight "
            f"{BACK_SAMPLING_WEIGHT:g}; --one-sided-light leaves them out)")

    # Point lights: raylab's path tracer skips `whitted_only` ones; others
    # (radiant intensity I = π·color·intensity, inverse square) would be
    # Mitsuba `point` emitters.
    points = []
    for light in doc.get("light", []):
        if light.get("whitted_only", False):
            notes.append(f"point light at {light['position']}: whitted_only, skipped (as raylab's path tracer does)")
            continue
        if light.get("falloff", "none") != "inverse_square":
            raise ValueError("a point light without inverse-square falloff has no Mitsuba equivalent")
        c, i = light.get("color", [1.0, 1.0, 1.0]), float(light.get("intensity", 1.0))
        points.append({"position": light["position"], "intensity": [math.pi * x * i for x in c]})

    cam = doc["camera"]
    w, h = args.width, args.height
    if "aspect" in cam and abs(float(cam["aspect"]) - w / h) > 1e-6:
        raise ValueError("a camera aspect other than width/height is not converted")
    # raylab's `fov` is the vertical view angle (crates/core/src/camera.rs: H = N·tan(θ/2),
    # W = H·aspect), so fov_axis = "y". Its rays start at the eye (the near
    # plane only scales the image plane), hence a tiny near_clip.
    spec = {
        "eye": cam["eye"], "look_at": cam["look_at"], "up": cam.get("up", [0.0, 1.0, 0.0]),
        "fov": float(cam["fov"]), "width": w, "height": h, "filter": rfilter,
        # raylab's path:K: K bounces after the camera hit, the last vertex's
        # BRDF ray still collecting emission (crates/core/src/integrator/path.rs), so its
        # longest path has K + 2 segments: camera → x1 → … → x_{K+1} →
        # emitter. Mitsuba's max_depth counts segments (1 = emitters seen
        # directly, 2 = direct light), so path:K = max_depth K + 2 (path:4 =
        # 6, as in the issue). --rr-depth off = rr_depth above max_depth.
        "max_depth": args.bounces + 2, "rr_depth": args.bounces + 100,
        "spp": args.spp, "shapes": shapes, "points": points,
    }
    notes.append(f"geometry: {n_tri} triangles (+ {n_copies} reversed emitter copies) in {len(shapes)} "
                 f"PLY meshes, {len(emitters)} area emitter(s)")
    notes.append(f"integrator: raylab path:{args.bounces} --rr-depth off = Mitsuba path max_depth "
                 f"{spec['max_depth']}, rr_depth {spec['rr_depth']}")
    notes.append(f"camera: fov {spec['fov']:g}° vertical (fov_axis y), eye {spec['eye']}, "
                 f"look_at {spec['look_at']}, up {spec['up']}; film {w}×{h}, {rfilter} filter; "
                 f"sampler independent {args.spp} spp")
    return spec, notes


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def mitsuba_dict(spec: dict, mi) -> dict:
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": spec["max_depth"],
                       "rr_depth": spec["rr_depth"], "hide_emitters": False},
        "sensor": {
            "type": "perspective",
            "fov": spec["fov"], "fov_axis": "y", "near_clip": 1e-3, "far_clip": 1e7,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=spec["eye"], target=spec["look_at"], up=spec["up"]),
            "sampler": {"type": "independent", "sample_count": spec["spp"]},
            "film": {"type": "hdrfilm", "width": spec["width"], "height": spec["height"],
                     "pixel_format": "rgb", "component_format": "float32",
                     "rfilter": {"type": spec["filter"]}},
        },
    }
    for s in spec["shapes"]:
        shape = {
            "type": "ply", "filename": s["ply"], "face_normals": True,
            "bsdf": {"type": "twosided",
                     "bsdf": {"type": "diffuse",
                              "reflectance": {"type": "rgb", "value": s["albedo"]}}},
        }
        if any(e > 0 for e in s["emission"]):
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": s["emission"]},
                                "sampling_weight": s.get("sampling_weight", 1.0)}
        d[f"shape-{s['name']}"] = shape
    for k, p in enumerate(spec["points"]):
        d[f"point-{k}"] = {"type": "point", "position": p["position"],
                           "intensity": {"type": "rgb", "value": p["intensity"]}}
    return d


# --------------------------------------------------------------------------
# The Mitsuba worker: one process per variant, driven over stdin/stdout
# --------------------------------------------------------------------------


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def thread_cpu_seconds() -> dict[str, float]:
    """CPU seconds of each of this process's threads (Linux /proc)."""
    out = {}
    tick = os.sysconf("SC_CLK_TCK")
    for t in os.listdir("/proc/self/task"):
        try:
            f = Path(f"/proc/self/task/{t}/stat").read_text().rsplit(")", 1)[1].split()
            out[t] = (int(f[11]) + int(f[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return out


# Instruction sets an LLVM variant can be held to (`VARIANT@ISA`): LLVM's
# CPU name, its features, and the lanes per kernel instruction. Dr.Jit picks
# the widest the CPU has (16 lanes with AVX-512); `avx2` holds it to the
# 8 lanes raylab's SIMD code uses, so that the two compare at equal width.
LLVM_ISAS = {
    "avx2": ("haswell", "+sse4.2,+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+lzcnt,+popcnt", 8),
}


def set_llvm_isa(dr, isa: str) -> dict:
    """Hold Dr.Jit's LLVM back end to `isa` (empty: leave its own choice) and
    say what it compiles for. Dr.Jit's Python API does not expose the setter,
    so it is called in its core library (C++ names of Dr.Jit 1.x)."""
    import ctypes
    lib = ctypes.CDLL(str(Path(dr.__file__).parent / "libdrjit-core.so"))
    try:
        set_target = lib["_Z19jit_llvm_set_targetPKcS0_j"]
        get_cpu = lib["_Z19jit_llvm_target_cpuv"]
        get_features = lib["_Z24jit_llvm_target_featuresv"]
        get_width = lib["_Z21jit_llvm_vector_widthv"]
    except AttributeError as e:
        die(f"this Dr.Jit ({dr.__version__}) lacks the LLVM target functions bench-peers uses: {e}")
    get_cpu.restype = get_features.restype = ctypes.c_char_p
    get_width.restype = ctypes.c_uint32
    if isa:
        cpu, features, width = LLVM_ISAS[isa]
        set_target(cpu.encode(), features.encode(), ctypes.c_uint32(width))
    return {"isa": isa or "native", "cpu": (get_cpu() or b"").decode(),
            "features": (get_features() or b"").decode(), "vector_width": get_width()}


def worker(variant: str, spec_path: str, threads: int, image_out: str) -> None:
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    def reply(obj):
        sys.stdout.write(PROTOCOL + json.dumps(obj) + "\n")
        sys.stdout.flush()

    variant, _, isa = variant.partition("@")
    mi.set_variant(variant)
    llvm = set_llvm_isa(dr, isa) if variant.startswith("llvm") else None
    mi.set_log_level(mi.LogLevel.Warn)
    # Dr.Jit's thread pool (nanothread) runs both the scalar variant's
    # render blocks and the LLVM variant's kernels.
    dr.set_thread_count(threads)
    spec = json.loads(Path(spec_path).read_text())
    t0 = time.perf_counter()
    scene = mi.load_dict(mitsuba_dict(spec, mi))
    load_s = time.perf_counter() - t0
    reply({"ready": True, "load_s": load_s, "threads": dr.thread_count(),
           "mitsuba": mi.__version__, "drjit": dr.__version__, "llvm_target": llvm})
    total, n = None, 0
    sq = None
    threads_before = thread_cpu_seconds()
    for line in sys.stdin:
        cmd = line.split()
        if not cmd:
            continue
        if cmd[0] == "render":
            seed = int(cmd[1])
            c0, t0 = cpu_seconds(), time.perf_counter()
            img = mi.render(scene, spp=spec["spp"], seed=seed)
            a = np.array(img, dtype=np.float64)  # forces evaluation
            wall = time.perf_counter() - t0
            cpu = cpu_seconds() - c0
            total = a if total is None else total + a
            sq = a * a if sq is None else sq + a * a
            n += 1
            reply({"seed": seed, "wall_s": wall, "cpu_s": cpu, "mean": a.mean(axis=(0, 1)).tolist()})
        elif cmd[0] == "quit":
            break
    if n:
        mean = total / n
        var = np.maximum(sq / n - mean * mean, 0.0) * n / max(n - 1, 1)
        np.save(image_out, np.stack([mean, var], axis=0))
    # Which threads did the renders' work: with --threads T, T of them
    # (the pool's workers and the calling thread).
    after = thread_cpu_seconds()
    busy = sorted((after[t] - threads_before.get(t, 0.0) for t in after), reverse=True)
    reply({"done": True, "renders": n, "thread_cpu_s": busy})


class Worker:
    def __init__(self, variant, spec_path, threads, image_out, env):
        self.variant = variant
        self.image_out = image_out
        cmd = [sys.executable, __file__, "--worker", variant, "--spec", str(spec_path),
               "--threads", str(threads), "--worker-image", str(image_out)]
        self.p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  text=True, env=env, bufsize=1)
        self.chatter: list[str] = []

    def read(self) -> dict:
        for line in self.p.stdout:
            if line.startswith(PROTOCOL):
                return json.loads(line[len(PROTOCOL):])
            self.chatter.append(line.rstrip())
        code = self.p.wait()
        die(f"Mitsuba worker {self.variant} ended (status {code}) without answering; its output:\n  "
            + "\n  ".join(self.chatter[-30:]))

    def send(self, line: str) -> dict:
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()
        return self.read()

    def close(self) -> dict:
        r = self.send("quit")
        self.p.wait()
        return r


# --------------------------------------------------------------------------
# raylab
# --------------------------------------------------------------------------


def raylab_command(args, out_exr: Path) -> list[str]:
    return [args.raylab, "render", str(args.scene), "--integrator", f"path:{args.bounces}",
            "--sampler", f"random:{args.spp}", "--accel", "bvh", "--width", str(args.width),
            "--height", str(args.height), "--rr-depth", "off", "--threads", str(args.threads),
            "-o", str(out_exr)]


def run_raylab(cmd: list[str]) -> dict:
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        die(f"raylab failed (status {p.returncode}): {' '.join(cmd)}\n{p.stdout}{p.stderr}")
    m = re.search(r"render ([0-9.]+) s, ([0-9.]+) Mrays/s", p.stdout)
    rays = re.search(r"rays\s+(\d+) total", p.stdout)
    if not m:
        die(f"could not find raylab's render time in its output:\n{p.stdout}")
    return {"wall_s": wall, "cpu_s": (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime),
            "render_s": float(m.group(1)), "mrays_per_s": float(m.group(2)),
            "rays": int(rays.group(1)) if rays else None, "stdout": p.stdout}


# --------------------------------------------------------------------------
# Comparing the images
# --------------------------------------------------------------------------


def compare(raylab_exr: Path, mitsuba_npy: Path, np, mi) -> dict:
    """Mean RGB of each image over the whole frame and its four halves, the
    relative difference Mitsuba/raylab − 1 and its z score (difference over
    the Monte Carlo standard error of the two means: raylab's from the EXR's
    per-pixel sample variances, Mitsuba's from the spread of its renders)."""
    bmp = mi.Bitmap(str(raylab_exr))
    names = [f.name for f in bmp.struct_()]
    a = np.array(bmp, dtype=np.float64)
    ch = lambda n: a[:, :, names.index(n)]  # noqa: E731
    rl = np.stack([ch("R"), ch("G"), ch("B")], axis=2)
    rl_var = np.stack([ch("variance.R"), ch("variance.G"), ch("variance.B")], axis=2) / ch("count")[:, :, None]
    mean_var = np.load(mitsuba_npy)
    mt, mt_var = mean_var[0], mean_var[1]  # mt_var: variance of one render's pixel
    h, w = rl.shape[:2]
    regions = {"image": (slice(None), slice(None)), "left half": (slice(None), slice(0, w // 2)),
               "right half": (slice(None), slice(w // 2, None)), "top half": (slice(0, h // 2), slice(None)),
               "bottom half": (slice(h // 2, None), slice(None))}
    out = {}
    for name, (ys, xs) in regions.items():
        r, m = rl[ys, xs], mt[ys, xs]
        npx = r.shape[0] * r.shape[1]
        rm, mm = r.mean(axis=(0, 1)), m.mean(axis=(0, 1))
        se_r = np.sqrt(rl_var[ys, xs].sum(axis=(0, 1))) / npx
        out[name] = {"raylab": rm.tolist(), "mitsuba": mm.tolist(), "se_raylab": se_r.tolist(),
                     "mt_pixel_var_sum": mt_var[ys, xs].sum(axis=(0, 1)).tolist(), "pixels": npx,
                     # noise at equal spp: Mitsuba's pixel variance over raylab's
                     "variance_ratio": (mt_var[ys, xs].sum(axis=(0, 1))
                                        / rl_var[ys, xs].sum(axis=(0, 1))).tolist()}
    return out


def finish_compare(cmp: dict, renders: int, tolerance: float) -> tuple[dict, bool]:
    ok = True
    for name, c in cmp.items():
        npx = c["pixels"]
        se_m = [math.sqrt(v / renders) / npx for v in c["mt_pixel_var_sum"]]
        rel, z = [], []
        for k in range(3):
            d = c["mitsuba"][k] - c["raylab"][k]
            rel.append(d / c["raylab"][k] if c["raylab"][k] else float("nan"))
            se = math.hypot(c["se_raylab"][k], se_m[k])
            z.append(d / se if se else float("nan"))
        c.update({"se_mitsuba": se_m, "rel_diff": rel, "z": z})
        del c["mt_pixel_var_sum"]
        limit = tolerance if name == "image" else 2 * tolerance
        c["agree"] = all(abs(x) <= limit for x in rel)
        ok &= c["agree"]
    return cmp, ok


# --------------------------------------------------------------------------
# The run
# --------------------------------------------------------------------------


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def git_revision() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return rev + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(
        prog="scripts/bench-peers",
        description="raylab against Mitsuba 3 (scalar_rgb and llvm_ad_rgb) on the same scene, "
                    "same spp and thread count, timed side by side; images compared.")
    ap.add_argument("--scene", type=Path, default=REPO / "data/scenes/cornell-box.toml")
    ap.add_argument("--raylab", default=os.environ.get("RAYLAB", str(REPO / "target/release/raylab")),
                    help="raylab binary (default $RAYLAB or target/release/raylab)")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel (default 256)")
    ap.add_argument("--runs", type=int, default=3, help="timed runs of each tool (default 3; median reported)")
    ap.add_argument("--threads", type=int, default=2, help="threads for every tool (default 2)")
    ap.add_argument("--bounces", type=int, default=4, help="raylab path:K (default 4 = Mitsuba max_depth 6)")
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--height", type=int, default=128)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb,llvm_ad_rgb@avx2",
                    help="Mitsuba variants (default scalar_rgb,llvm_ad_rgb,llvm_ad_rgb@avx2); "
                         "an LLVM variant with @avx2 is held to AVX2's 8 lanes, raylab's SIMD width "
                         "(without it Dr.Jit uses the widest the CPU has: 16 lanes with AVX-512)")
    ap.add_argument("--one-sided-light", action="store_true",
                    help="give Mitsuba one-sided emitters only (raylab's are two-sided; by default "
                         "Mitsuba gets reversed copies of the emitting triangles to match)")
    ap.add_argument("--tolerance", type=float, default=0.01,
                    help="largest relative difference of the mean colours taken as agreement "
                         "(default 0.01; twice that for the halves)")
    ap.add_argument("--out", type=Path, help="write bench-peers.json and bench-peers.csv here")
    ap.add_argument("--note", default="",
                    help="free text recorded in bench-peers.json (e.g. where the raylab binary was built from)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--spec", help=argparse.SUPPRESS)
    ap.add_argument("--worker-image", help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.worker:
        worker(args.worker, args.spec, args.threads, args.worker_image)
        return
    for name in ("spp", "runs", "threads", "width", "height"):
        if getattr(args, name) < 1:
            die(f"--{name} must be at least 1")
    if args.bounces < 0:
        die("--bounces must be at least 0")
    try:
        import drjit as dr
        import mitsuba as mi
        import numpy as np
    except ImportError as e:
        die(f"{e}: run this through scripts/bench-peers, which installs Mitsuba into .deps/peers-venv")
    if not (Path(args.raylab).is_file() and os.access(args.raylab, os.X_OK)):
        die(f"no raylab binary at {args.raylab} (cargo build --release, or --raylab PATH)")
    args.scene = args.scene.resolve()
    variants = [v for v in args.variants.split(",") if v]
    for v in variants:
        name, at, isa = v.partition("@")
        if name not in mi.variants():
            die(f"Mitsuba variant {name!r} is not in this build (it has {', '.join(mi.variants())})")
        if at and not (name.startswith("llvm") and isa in LLVM_ISAS):
            die(f"--variants: {v!r}: only LLVM variants take @ISA, and ISA is one of "
                f"{', '.join(LLVM_ISAS)}")
        if variants.count(v) > 1:
            die(f"--variants: {v!r} is named twice")

    tmp = Path(tempfile.mkdtemp(prefix="raylab-bench-peers."))
    try:
        run(args, variants, tmp, mi, dr, np)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def run(args, variants, tmp: Path, mi, dr, np) -> None:
    try:
        spec, notes = convert(args.scene, args, tmp)
    except (ValueError, KeyError, OSError) as e:
        die(f"{args.scene}: cannot convert for Mitsuba: {e}")
    spec_path = tmp / "spec.json"
    spec_path.write_text(json.dumps(spec))
    samples = args.width * args.height * args.spp
    rl_version = subprocess.run([args.raylab, "--version"], capture_output=True, text=True).stdout.strip()
    started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    binary_mtime = Path(args.raylab).stat().st_mtime
    load_before = os.getloadavg()

    scene_name = str(args.scene.relative_to(REPO) if args.scene.is_relative_to(REPO) else args.scene)
    print(f"bench-peers: {scene_name}, "
          f"{args.width}×{args.height}, {args.spp} spp, {args.threads} threads, {args.runs} timed runs each")
    print(f"machine: {cpu_model()}, {os.cpu_count()} logical CPUs; load average "
          f"{load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f} (1, 5, 15 min)")
    for n in notes:
        print(f"  {n}")

    # Mitsuba workers: each its own process and empty kernel cache, so the
    # warm-up render includes compiling the LLVM kernels.
    workers, info = {}, {}
    for v in variants:
        env = dict(os.environ)
        env["DRJIT_CACHE_DIR"] = str(tmp / f"drjit-cache-{v}")
        w = Worker(v, spec_path, args.threads, tmp / f"{v}.npy", env)
        info[v] = w.read()
        workers[v] = w
        if t := info[v].get("llvm_target"):
            print(f"mitsuba {v}: LLVM kernels for {t['cpu']}, {t['vector_width']} lanes")
    rl_cmd = raylab_command(args, tmp / "raylab.exr")
    print(f"raylab: {' '.join(rl_cmd)}")

    runs = []  # rows: tool, kind, index, wall_s, cpu_s, render_s, load1

    def record(tool, kind, k, r):
        row = {"tool": tool, "kind": kind, "run": k, "wall_s": r["wall_s"], "cpu_s": r["cpu_s"],
               "render_s": r.get("render_s", r["wall_s"]), "load1": os.getloadavg()[0]}
        runs.append(row)
        return row

    # Warm-ups: raylab once (page cache: the binary is large), each Mitsuba
    # variant once (scene set-up, kernel compilation for LLVM).
    print("warm-up ...", flush=True)
    r = run_raylab(rl_cmd)
    record("raylab", "warm-up", 0, r)
    rl_out = r
    for v, w in workers.items():
        record(f"mitsuba {v}", "warm-up", 0, w.send("render 0"))
    for k in range(1, args.runs + 1):
        print(f"run {k}/{args.runs} ...", flush=True)
        rl_out = run_raylab(rl_cmd)
        record("raylab", "timed", k, rl_out)
        for v, w in workers.items():
            record(f"mitsuba {v}", "timed", k, w.send(f"render {k}"))
    finals = {v: w.close() for v, w in workers.items()}
    load_after = os.getloadavg()
    binary_changed = Path(args.raylab).stat().st_mtime != binary_mtime
    if binary_changed:
        print(f"warning: {args.raylab} was rebuilt during the run: its timings mix two builds",
              file=sys.stderr)

    # The table.
    tools = ["raylab"] + [f"mitsuba {v}" for v in variants]
    summary = {}
    for t in tools:
        timed = [r for r in runs if r["tool"] == t and r["kind"] == "timed"]
        warm = [r for r in runs if r["tool"] == t and r["kind"] == "warm-up"][0]
        summary[t] = {"wall_s": median([r["wall_s"] for r in timed]),
                      "render_s": median([r["render_s"] for r in timed]),
                      "cpu_s": median([r["cpu_s"] for r in timed]),
                      "warmup_s": warm["wall_s"],
                      "wall_runs": [r["wall_s"] for r in timed]}
        s = summary[t]
        s["msamples_per_s"] = samples / s["wall_s"] / 1e6
        s["cpu_per_wall"] = s["cpu_s"] / s["wall_s"]
    rl = summary["raylab"]
    print()
    name_w = max(len(t) for t in tools)
    print(f"{'':{name_w}} {'median s':>9} {'runs (s)':>24} {'render s':>9} {'CPU s':>7} {'CPU/wall':>8} "
          f"{'Msamples/s':>10} {'warm-up s':>9} {'raylab/this':>11} {'(CPU s)':>7}")
    for t in tools:
        s = summary[t]
        runs_s = " ".join(f"{x:.2f}" for x in s["wall_runs"])
        ratio = "" if t == "raylab" else f"{rl['wall_s'] / s['wall_s']:.2f}"
        ratio_cpu = "" if t == "raylab" else f"{rl['cpu_s'] / s['cpu_s']:.2f}"
        print(f"{t:{name_w}} {s['wall_s']:9.3f} {runs_s:>24} {s['render_s']:9.3f} {s['cpu_s']:7.2f} "
              f"{s['cpu_per_wall']:8.2f} {s['msamples_per_s']:10.2f} {s['warmup_s']:9.2f} {ratio:>11} "
              f"{ratio_cpu:>7}")
        if t != "raylab":
            s["raylab_over_this_wall"] = rl["wall_s"] / s["wall_s"]
            s["raylab_over_this_cpu"] = rl["cpu_s"] / s["cpu_s"]
    print(f"raylab: process wall clock (start to end), `render` = the render time it prints "
          f"({rl_out['mrays_per_s']:.2f} Mrays/s, {rl_out['rays']} rays per run); Mitsuba: mi.render "
          f"wall clock in a warm process. Msamples/s = {samples / 1e6:.2f} M camera samples / median s. "
          f"raylab/this: ratio of the medians of wall-clock (and of CPU) seconds; > 1: raylab is slower.")
    for v in variants:
        busy = finals[v].get("thread_cpu_s", [])
        worked = [x for x in busy if busy and x > 0.25 * busy[0]]
        summary[f"mitsuba {v}"]["threads_that_worked"] = len(worked)
        print(f"mitsuba {v}: {len(worked)} threads did the work (CPU s each: "
              f"{' '.join(f'{x:.1f}' for x in worked)})")
        if len(worked) != args.threads:
            print(f"warning: mitsuba {v} ran on {len(worked)} threads, not --threads {args.threads}",
                  file=sys.stderr)
    for t in tools:
        if summary[t]["cpu_per_wall"] > args.threads + 0.25:
            print(f"warning: {t} used {summary[t]['cpu_per_wall']:.2f} CPUs on average, more than "
                  f"--threads {args.threads}", file=sys.stderr)
    print(f"load average after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}")

    # The images.
    comparisons, all_ok = {}, True
    var_w = max([12] + [len(v) for v in variants])
    print()
    print(f"mean RGB, raylab (seed 0) vs Mitsuba (mean of its {args.runs + 1} renders); "
          "rel = Mitsuba/raylab − 1, z = difference / Monte Carlo standard error")
    for v in variants:
        cmp = compare(tmp / "raylab.exr", tmp / f"{v}.npy", np, mi)
        cmp, ok = finish_compare(cmp, args.runs + 1, args.tolerance)
        comparisons[v] = cmp
        all_ok &= ok
        for name, c in cmp.items():
            fmt = lambda xs: " ".join(f"{x:.5f}" for x in xs)  # noqa: E731
            rel = " ".join(f"{100 * x:+.2f}%" for x in c["rel_diff"])
            z = " ".join(f"{x:+.1f}" for x in c["z"])
            flag = "ok" if c["agree"] else "DIFFERENT"
            print(f"  {v:{var_w}} {name:11} raylab {fmt(c['raylab'])}  mitsuba {fmt(c['mitsuba'])}  "
                  f"rel {rel}  z {z}  {flag}")
        vr = " ".join(f"{x:.2f}" for x in cmp["image"]["variance_ratio"])
        print(f"  {v:{var_w}} pixel variance at {args.spp} spp, Mitsuba/raylab (R G B): {vr} "
              f"(Mitsuba's from the spread of {args.runs + 1} renders: rough)")

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        meta = {
            "what": "raylab vs Mitsuba 3, same scene, spp and threads (scripts/bench-peers)",
            "note": args.note,
            "date": started, "machine": {
                "cpu_model": cpu_model(), "logical_cpus": os.cpu_count(), "platform": platform.platform(),
                "load_average_before": load_before, "load_average_after": load_after},
            "versions": {"raylab": rl_version, "raylab_binary": str(args.raylab),
                         "raylab_binary_modified": _dt.datetime.fromtimestamp(
                             binary_mtime, _dt.timezone.utc).isoformat(timespec="seconds"),
                         "raylab_binary_rebuilt_during_run": binary_changed,
                         # the checkout this script ran from; the binary may be another's
                         "repository_revision": git_revision(),
                         "mitsuba": info[variants[0]]["mitsuba"] if variants else None,
                         "drjit": info[variants[0]]["drjit"] if variants else None,
                         "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH"), "python": platform.python_version()},
            "settings": {"scene": scene_name,
                         "width": args.width, "height": args.height, "spp": args.spp, "threads": args.threads,
                         "runs": args.runs, "bounces": args.bounces, "variants": variants,
                         "one_sided_light": args.one_sided_light, "tolerance": args.tolerance},
            "raylab_command": " ".join(["raylab", "render", scene_name] + rl_cmd[3:-2] + ["-o", "OUT.exr"]),
            "mitsuba_scene": {k: v for k, v in spec.items() if k != "shapes"}
            | {"shapes": [{k: v for k, v in s.items() if k != "ply"} for s in spec["shapes"]]},
            "conversion_notes": notes,
            "mitsuba_workers": info, "summary": summary, "runs": runs, "image_comparison": comparisons,
            "images_agree": all_ok,
        }
        (args.out / "bench-peers.json").write_text(json.dumps(meta, indent=2) + "\n")
        with (args.out / "bench-peers.csv").open("w") as f:
            f.write("date,cpu_model,threads,spp,width,height,tool,kind,run,wall_s,render_s,cpu_s,load1\n")
            for r in runs:
                f.write(f"{started},\"{cpu_model()}\",{args.threads},{args.spp},{args.width},{args.height},"
                        f"{r['tool']},{r['kind']},{r['run']},{r['wall_s']:.4f},{r['render_s']:.4f},"
                        f"{r['cpu_s']:.4f},{r['load1']:.2f}\n")
        print(f"\nwrote {args.out / 'bench-peers.json'} and {args.out / 'bench-peers.csv'}")
    if not all_ok:
        die("the images' mean colours differ by more than --tolerance: the two scenes are not the "
            "same (fix the conversion before reading the timings)", 3)


if __name__ == "__main__":
    main()
