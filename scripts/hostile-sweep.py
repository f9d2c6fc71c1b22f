#!/usr/bin/env python3
"""Hostile-input sweep: a few hundred bad or extreme command lines against the softshadow
binary, each checked for a non-zero exit, exactly one `error:` line, no panic, no signal, no
validation message, and an output folder left exactly as it was.

    scripts/hostile-sweep.py [BINARY]     (default target/release/softshadow, else debug)

Prints one line per failed input and the counts; exits non-zero when any input failed.
Every command runs in its own scratch folder under $TMPDIR with lavapipe and --validation.
"""

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SMALL = ["--width", "24", "--height", "24"]


def techniques(exe):
    """Every technique but `reference`, as the binary lists them (its usage error for an
    unknown --technique names the allowed values), so new techniques are swept too."""
    p = subprocess.run([exe, "render", "--technique", "?"], capture_output=True, text=True)
    line = next((l for l in p.stderr.splitlines() if "allowed" in l), "")
    names = [n.strip() for n in line.split("allowed", 1)[-1].split(",") if n.strip()]
    if not names:
        sys.exit(f"cannot read the technique list from: {p.stderr.strip()}")
    return [n for n in names if n != "reference"]


def binary():
    if len(sys.argv) > 1:
        return os.path.abspath(sys.argv[1])
    for kind in ("release", "debug"):
        path = os.path.join(ROOT, "target", kind, "softshadow")
        if os.path.exists(path):
            return path
    sys.exit("no softshadow binary: cargo build --release first")


def snapshot(folder):
    """Every entry under `folder` with a hash of its bytes or its kind."""
    out = {}
    for base, dirs, files in os.walk(folder):
        for d in dirs:
            out[os.path.relpath(os.path.join(base, d), folder)] = "<dir>"
        for f in files:
            p = os.path.join(base, f)
            rel = os.path.relpath(p, folder)
            if os.path.islink(p):
                out[rel] = "<link>" + os.readlink(p)
            elif os.path.isfile(p):
                with open(p, "rb") as fh:
                    out[rel] = hashlib.sha1(fh.read()).hexdigest()
            else:
                out[rel] = "<special>"
    return out


def obj(lines):
    return "\n".join(lines) + "\n"


TRI = ["v 0 0 0", "v 1 0 0", "v 0 1 0"]

# (file name, content): inputs written into each scratch folder before a command runs.
FILES = {
    "junk.obj": obj(TRI + ["hello world", "f 1 2 3"]),
    "short_v.obj": obj(["v 0 0 0", "v 1 2", "v 0 1 0", "f 1 2 3"]),
    "two_f.obj": obj(TRI + ["f 1 2"]),
    "vt_range.obj": obj(TRI + ["vt 0 0", "vn 0 0 1", "f 1/2/3 2/9/9 3"]),
    "vn_range.obj": obj(TRI + ["vt 0 0", "f 1/1/1 2/1/1 3/1/1"]),
    "v_range.obj": obj(TRI + ["f 1 2 9"]),
    "neg_range.obj": obj(TRI + ["f -1 -2 -9"]),
    "zero_idx.obj": obj(TRI + ["f 0 1 2"]),
    "nan.obj": obj(["v 0 nan 0", "v 1 0 0", "v 0 1 0", "f 1 2 3"]),
    "inf.obj": obj(["v 0 inf 0", "v 1 0 0", "v 0 1 0", "f 1 2 3"]),
    "word.obj": obj(["v 0 zero 0", "v 1 0 0", "v 0 1 0", "f 1 2 3"]),
    "empty.obj": "",
    "nofaces.obj": obj(TRI),
    "collinear.obj": obj(["v 0 0 0", "v 1 0 0", "v 2 0 0", "f 1 2 3"]),
    "specks.obj": obj(["v 0 0 0", "v 1e-40 0 0", "v 0 1e-40 0", "f 1 2 3"]),
    "huge.obj": obj(["v -1e38 0 0", "v 1e38 0 0", "v 0 0 1e38", "f 1 2 3"]),
    "longtoken.obj": obj(["v 0 0 " + "9" * 200000 + "x", "v 1 0 0", "v 0 1 0", "f 1 2 3"]),
    "binary.obj": "\x00\xff\xfe garbage",
    "face_word.obj": obj(TRI + ["f 1 x 3"]),
    "bad.toml": "this is = = not toml\n",
    "unknown_key.toml": "[[object]]\nprimitive = \"box\"\nradus = 1\n",
    "fov178.toml": "[[object]]\nprimitive = \"box\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n[light]\nfov_deg = 178\n",
    "fov0.toml": "[[object]]\nprimitive = \"box\"\n[light]\nfov_deg = 0\n",
    "scale0.toml": "[[object]]\nprimitive = \"box\"\nscale = 0\n",
    "scale1e8.toml": "[[object]]\nprimitive = \"box\"\nscale = 1e8\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n",
    "scale1e-9.toml": "[[object]]\nprimitive = \"box\"\nscale = 1e-9\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\nscale = 1e-9\n",
    "noreceiver.toml": "[[object]]\nprimitive = \"box\"\nrole = \"caster\"\n",
    "nocaster.toml": "[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n",
    "negradius.toml": "[[object]]\nprimitive = \"box\"\n[light]\nradius = -1\n",
    "nanpos.toml": "[[object]]\nprimitive = \"box\"\ntranslate = [0, nan, 0]\n",
    "missingmesh.toml": "[[object]]\nmesh = \"nope.obj\"\n",
    "both.toml": "[[object]]\nmesh = \"junk.obj\"\nprimitive = \"box\"\n",
    "neither.toml": "[[object]]\nrole = \"both\"\n",
    "badprim.toml": "[[object]]\nprimitive = \"teapot\"\n",
    "badrole.toml": "[[object]]\nprimitive = \"box\"\nrole = \"shiny\"\n",
    "junkmesh.toml": "[[object]]\nmesh = \"junk.obj\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n",
    "notascene.txt": "hello\n",
    "bad_icd.json": "{ not json",
    "afile": "keep",
}


def cases(exe):
    """(label, args, env) for every bad input."""
    out = []
    r = ["render"] + SMALL

    def add(label, args, env=None):
        out.append((label, args, env or {}))

    # Outputs that are not regular files or cannot be written.
    for t in ("hard", "smoothies"):
        for target, what in [
            ("/dev/full", "device node"),
            ("/dev/null", "device node"),
            ("fifo.png", "fifo"),
            ("full.png", "link to a device"),
            ("adir.png", "folder"),
            ("nowhere/x.png", "missing folder"),
            ("x.jpg", "jpg"),
            ("x", "no extension"),
            ("afile/x.png", "under a file"),
        ]:
            add(f"render --out {what} ({t})", r + ["--technique", t, "--out", target])
        for flag in ("--aov", "--buffers"):
            for target in ("afile", "fifo.png", "afile/sub", "full.png"):
                add(f"render {flag} {target} ({t})", r + ["--technique", t, "--out", "o.png", flag, target])
    for target in ("/dev/full", "fifo.png", "fifo_pair.obj", "adir.png", "nowhere/x.obj", "full.png"):
        add(f"export --obj {target}", ["export", "--obj", target])
    for target in ("afile", "fifo.png", "afile/sub", "full.png"):
        add(f"bench --out {target}", ["bench", "--out", target])
        add(f"stress --out {target}", ["stress", "--quick", "--out", target])
    # Scenes.
    for f in sorted(FILES):
        if f.endswith((".obj", ".toml", ".txt")):
            add(f"render --scene {f}", r + ["--technique", "hard", "--scene", f, "--out", "o.png"])
            add(f"export --scene {f}", ["export", "--scene", f, "--obj", "o.obj"])
    for f in ("junk.obj", "short_v.obj", "fov178.toml", "scale1e8.toml", "specks.obj"):
        add(f"bench --scenes {f}", ["bench", "--scenes", f, "--techniques", "hard", "--out", "b"])
    add("render --scene no-such", r + ["--scene", "no-such", "--out", "o.png"])
    add("render --scene missing.obj", r + ["--scene", "missing.obj", "--out", "o.png"])
    # Numbers, per technique where the technique reads them.
    bad_sizes = ["0", "-1", "1e3", "abc", "", "99999999999", "9" * 100000, "nan"]
    for flag in ("--width", "--height"):
        for v in bad_sizes:
            add(f"render {flag} {v[:12]}", ["render", flag, v, "--out", "o.png"])
    for t in techniques(exe):
        for v in ["0", "1", "3", "63", "-1", "999999", "1.5"]:
            add(f"render {t} --shadow-res {v}", r + ["--technique", t, "--shadow-res", v, "--out", "o.png"])
        for v in ["-1", "nan", "inf", "1e30", "-inf"]:
            add(f"render {t} --light-radius {v}", r + ["--technique", t, "--light-radius", v, "--out", "o.png"])
    for t in [t for t in techniques(exe) if t.startswith("ssm")]:
        for v in ["0", "1", "3", "31", "4096", "16384", "-5"]:
            add(f"render {t} --occluder-res {v}", r + ["--technique", t, "--occluder-res", v, "--out", "o.png"])
        add(f"render {t} --accum-format r8", r + ["--technique", t, "--accum-format", "r8", "--out", "o.png"])
    for v in ["-0.1", "2", "nan"]:
        add(f"render --smoothie-t {v}", r + ["--smoothie-t", v, "--out", "o.png"])
    for v in ["box2", "box99", "poisson0", "poisson100", "gauss3", ""]:
        add(f"render --pcf-kernel {v}", r + ["--technique", "pcf", "--pcf-kernel", v, "--out", "o.png"])
    for v in ["-1", "100", "nan"]:
        add(f"render --normal-offset {v}", r + ["--normal-offset", v, "--out", "o.png"])
        add(f"render --depth-bias {v}", r + ["--depth-bias", v, "--out", "o.png"])
    for v in ["0", "255", "70000"]:
        add(f"render --reference-samples {v}", r + ["--technique", "reference", "--reference-samples", v, "--out", "o.png"])
    for flag, v in [("--technique", "nope"), ("--spirv", "fast"), ("--silhouettes", "tpu"), ("--device", "NoSuchGpu")]:
        add(f"render {flag} {v}", r + [flag, v, "--out", "o.png"])
    b = ["bench", "--out", "b", "--techniques", "hard", "--scenes", "cylinder"]
    for flag, v in [
        ("--resolutions", "0"), ("--resolutions", "3"), ("--resolutions", "99999"), ("--resolutions", "-1"),
        ("--resolutions", ""), ("--radii", "-1"), ("--radii", "nanx"), ("--radii", "banana"),
        ("--frames", "0"), ("--frames", "-2"), ("--samples", "1"), ("--samples", "1000000"),
        ("--smoothie-t", "0"), ("--smoothie-t", "7"), ("--motion", "spin"), ("--width", "0"),
        ("--techniques", "nope"), ("--scenes", "nope"), ("--spirv", "fast"), ("--silhouettes", "tpu"),
    ]:
        add(f"bench {flag} {v[:12]}", b + [flag, v])
    for flag, v in [("--cases", "nope"), ("--techniques", "nope"), ("--techniques", "reference,nope")]:
        add(f"stress {flag} {v}", ["stress", "--quick", "--out", "s", flag, v])
    add("export --width 0", ["export", "--obj", "o.obj", "--width", "0"])
    add("export --scene nope", ["export", "--obj", "o.obj", "--scene", "nope"])
    # Drivers.
    for env in [
        {"VK_ICD_FILENAMES": "/nonexistent.json"},
        {"VK_ICD_FILENAMES": "bad_icd.json", "VK_DRIVER_FILES": "bad_icd.json"},
        {"VK_ICD_FILENAMES": "afile", "VK_DRIVER_FILES": "afile"},
    ]:
        add(f"render with {list(env.values())[0]}", r + ["--out", "o.png"], env)
    add("unknown subcommand", ["paint"])
    add("unknown flag", ["render", "--colour", "red"])
    out.extend(hostile_file_cases())
    return out


# Outputs (issue 47 item 5) and the narrow-cone cliff (item 6).
BOX_SCENE = "[[object]]\nprimitive = \"box\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n"


def narrow_cone(fov):
    """A box over a plane under a light of radius 1 about 9 units away, cone of `fov`."""
    return BOX_SCENE + ("[light]\nposition = [-3, 8, 2]\ntarget = [0, 0.5, 0]\nradius = 1\n"
                        f"fov_deg = {fov}\n")


# Labels of cases that must be refused before the device is opened (not after a sweep).
BEFORE_DEVICE = set()

# A render's AOVs and PNG, made once by `output_cases` and copied into every folder.
OUTPUT_INPUTS = {}


def prepare_outputs(folder):
    """Inputs that outputs may collide with: a scene and its links, named scenes for bench,
    a render's AOVs and PNGs for compare."""
    files = {
        "s.toml": BOX_SCENE,
        "named_cyl.toml": "name = \"cylinder\"\n" + BOX_SCENE,
        "named_ab1.toml": "name = \"a b\"\n" + BOX_SCENE,
        "named_ab2.toml": "name = \"a/b\"\n" + BOX_SCENE,
        "named_bang.toml": "name = \"!!\"\n" + BOX_SCENE,
        "named_what.toml": "name = \"??\"\n" + BOX_SCENE,
    }
    for name, text in files.items():
        with open(os.path.join(folder, name), "w") as fh:
            fh.write(text)
    os.mkdir(os.path.join(folder, "aovs"))
    for rel, data in OUTPUT_INPUTS.items():
        with open(os.path.join(folder, rel), "wb") as fh:
            fh.write(data)
    os.symlink("s.toml", os.path.join(folder, "scene_link.png"))
    os.symlink("s.toml", os.path.join(folder, "scene_link.obj"))
    os.symlink("s.toml", os.path.join(folder, "scene_link.json"))
    os.link(os.path.join(folder, "s.toml"), os.path.join(folder, "scene_hard.glb"))
    os.symlink("aovs/visibility.exr", os.path.join(folder, "vis_link.png"))


def output_cases(exe):
    """Outputs that are inputs, and bench scene-name clashes: refused before any work (bench
    before it opens the device, see `main`)."""
    with tempfile.TemporaryDirectory() as tmp:
        with open(os.path.join(tmp, "s.toml"), "w") as fh:
            fh.write(BOX_SCENE)
        subprocess.run([exe, "render", "--scene", "s.toml", "--technique", "hard", "--width", "16",
                        "--height", "16", "--aov", "aovs", "--out", "img_a.png"], cwd=tmp,
                       capture_output=True, check=True)
        for rel in ("aovs/visibility.exr", "aovs/position.exr", "aovs/normal.exr", "img_a.png"):
            with open(os.path.join(tmp, rel), "rb") as fh:
                OUTPUT_INPUTS[rel] = fh.read()
        OUTPUT_INPUTS["img_b.png"] = OUTPUT_INPUTS["img_a.png"]
    out = []
    r = ["render"] + SMALL + ["--technique", "hard"]
    cmp = ["compare", "--reference", "aovs", "--test", "aovs", "--light", "0,5,0"]
    for label, args in [
        ("render --out = --scene (symlink)", r + ["--scene", "s.toml", "--out", "scene_link.png"]),
        ("export --obj = --scene (symlink)", ["export", "--scene", "s.toml", "--obj", "scene_link.obj"]),
        ("export json = --scene (symlink)", ["export", "--scene", "./s.toml", "--obj", "scene_link.x"]),
        ("export --gltf = --scene (hard link)", ["export", "--scene", "s.toml", "--gltf", "scene_hard.glb"]),
        ("compare --out = --test-image", cmp + ["--reference-image", "img_a.png", "--test-image",
                                                "img_b.png", "--out", "./img_b.png"]),
        ("compare --out = --reference-image", cmp + ["--reference-image", "img_a.png", "--test-image",
                                                     "img_b.png", "--out", "img_a.png"]),
        ("compare --out = visibility.exr (symlink)", cmp + ["--out", "vis_link.png"]),
        ("bench two scenes named cylinder", ["bench", "--scenes", "cylinder,named_cyl.toml", "--out", "b"]),
        ("bench names reducing to one file name", ["bench", "--scenes", "named_ab1.toml,named_ab2.toml",
                                                   "--out", "b"]),
        ("bench names reducing to nothing", ["bench", "--scenes", "named_bang.toml,named_what.toml",
                                             "--out", "b"]),
    ]:
        out.append((label, args, {}))
        if args[0] == "bench":
            BEFORE_DEVICE.add(label)
    return out


def interrupt_and_cliff_checks(exe, base):
    """The number of checks, and (label, problem) for each failed one, of the classes the
    main loop cannot run: an
    export signalled mid-write must remove its partial file and exit non-zero with one
    error line; ssm-bitmask at 1 and 2 degree cones must render within
    60 s, with no line on stderr but the warning that names the micro-patch work bound."""
    failures = []
    env = dict(os.environ)
    env.pop("SOFTSHADOW_DEVICE", None)
    for sig in (signal.SIGINT, signal.SIGTERM):
        folder = tempfile.mkdtemp(dir=base)
        p = subprocess.Popen([exe, "export", "--scene", "dense-1m", "--obj", "o.obj"], cwd=folder,
                             env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        partial = os.path.join(folder, f".o.obj.partial-{p.pid}")
        deadline = time.time() + 300
        while p.poll() is None and time.time() < deadline:
            if os.path.exists(partial) and os.path.getsize(partial) > (1 << 20):
                break
            time.sleep(0.02)
        label = f"export interrupted by {signal.Signals(sig).name}"
        if p.poll() is not None:
            failures.append((label, "export ended before it was signalled"))
            continue
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        err = err.decode("utf-8", "replace")
        problems = []
        if p.returncode == 0:
            problems.append("exit 0")
        if sum(1 for line in err.splitlines() if line.startswith("error")) != 1:
            problems.append("error lines != 1")
        if os.listdir(folder):
            problems.append("left files: " + ", ".join(sorted(os.listdir(folder))))
        if problems:
            failures.append((label, ", ".join(problems)))
    for fov in (1, 2):
        folder = tempfile.mkdtemp(dir=base)
        with open(os.path.join(folder, "cone.toml"), "w") as fh:
            fh.write(narrow_cone(fov))
        for t in ("ssm-bitmask",):
            label = f"render {t} at a {fov} degree cone"
            try:
                p = subprocess.run([exe, "render", "--scene", "cone.toml", "--technique", t, "--width",
                                    "48", "--height", "48", "--out", "o.png", "--validation"],
                                   cwd=folder, env=env, capture_output=True, timeout=60)
            except subprocess.TimeoutExpired:
                failures.append((label, "timeout (60 s)"))
                continue
            # The one line allowed: the warning that names the micro-patch work bound.
            other = [line for line in p.stderr.decode().splitlines()
                     if line.strip() and not (line.startswith("warning: ") and "bound" in line)]
            if p.returncode != 0 or other:
                failures.append((label, f"exit {p.returncode}: {p.stderr.decode()[:200]}"))
    return 6, failures


def prepare(folder):
    for name, text in FILES.items():
        with open(os.path.join(folder, name), "w", encoding="latin-1") as fh:
            fh.write(text)
    os.mkfifo(os.path.join(folder, "fifo.png"))
    os.mkfifo(os.path.join(folder, "fifo_pair.json"))
    os.symlink("/dev/full", os.path.join(folder, "full.png"))
    os.mkdir(os.path.join(folder, "adir.png"))
    prepare_outputs(folder)
    prepare_hostile_files(folder)


# ---------------------------------------------------------------------------------------
# Hostile input files: node graphs, sizes and paths a scene file or a compare input may use
# to crash, hang, exhaust memory or read outside its folder. Generated once, hard-linked
# into each scratch folder (a hard link is a regular file inside the folder).
# ---------------------------------------------------------------------------------------

_HOSTILE_CACHE = None


def _tri_buffer(triangles):
    """Float VEC3 positions of `triangles` separate, non-degenerate triangles."""
    import struct
    vals = []
    for t in range(triangles):
        y = t * 1e-3
        vals += [0.0, y, 0.0, 1.0, y, 0.0, 0.0, y, 1.0]
    return struct.pack("<%df" % len(vals), *vals)


def _gltf(nodes, roots, meshes=1, buffer_uri="tri.bin", triangles=1, view=None, lights=None):
    """A glTF document whose meshes all read one POSITION accessor of `triangles` triangles
    from `buffer_uri`."""
    import json
    n = triangles * 3
    doc = {
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]} for _ in range(meshes)],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
                       "min": [0.0, 0.0, 0.0], "max": [1.0, max(triangles - 1, 0) * 1e-3, 1.0]}],
        "bufferViews": [dict({"buffer": 0, "byteLength": n * 12}, **(view or {}))],
        "buffers": [{"byteLength": n * 12, "uri": buffer_uri}],
    }
    if lights:
        doc["extensionsUsed"] = ["KHR_lights_punctual"]
        doc["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
    return json.dumps(doc)


def _exr_header(w, h, length):
    """A scanline EXR header declaring w x h float pixels of one channel, padded with zeros."""
    import struct
    b = bytearray(b"\x76\x2f\x31\x01\x02\x00\x00\x00")

    def attr(name, kind, value):
        b.extend(name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value)

    attr("channels", "chlist", b"Y\0" + struct.pack("<iiii", 2, 0, 1, 1) + b"\0")
    attr("compression", "compression", b"\0")
    window = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    attr("dataWindow", "box2i", window)
    attr("displayWindow", "box2i", window)
    attr("lineOrder", "lineOrder", b"\0")
    attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    attr("screenWindowCenter", "v2f", bytes(8))
    attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    b.extend(b"\0")
    return bytes(b) + bytes(max(0, length - len(b)))


def hostile_file_inputs():
    """(file name, bytes) of every generated hostile input."""
    ground = {"mesh": 0}
    chain = [{"children": [k + 1]} for k in range(12999)] + [{"mesh": 0}]
    ring = [{"mesh": 0, "children": [(k + 1) % 13000]} for k in range(13000)]
    twice = [{"mesh": 0, "children": [k + 1, k + 1]} for k in range(39)] + [{"mesh": 0}]
    twice_bare = [{"children": [k + 1, k + 1]} for k in range(39)] + [ground]
    many = [{"mesh": k} for k in range(2000)]
    spot = lambda angle: [{"type": "spot", "spot": {"outerConeAngle": angle}}]
    out = {
        "tri.bin": _tri_buffer(1),
        "big.bin": _tri_buffer(10000),
        "hf_chain.gltf": _gltf(chain, [0]),
        "hf_ring.gltf": _gltf(ring, [0]),
        "hf_twice.gltf": _gltf(twice, [0]),
        "hf_twice_bare.gltf": _gltf(twice_bare, [0]),
        "hf_many.gltf": _gltf(many, list(range(2000)), meshes=2000, buffer_uri="big.bin", triangles=10000),
        "hf_stride4.gltf": _gltf([ground], [0], view={"byteStride": 4}),
        "hf_projective.gltf": _gltf([dict(ground, matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1])], [0]),
        "hf_wide_cone.gltf": _gltf([ground, {"extensions": {"KHR_lights_punctual": {"light": 0}}}], [0, 1],
                                   lights=spot(1.6)),
        "hf_deep_json.gltf": _gltf([dict(ground, extras={"x": "DEEP"})], [0]).replace(
            '"DEEP"', "[" * 5000 + "]" * 5000),
        "hf_newline_name.gltf": _gltf([dict(ground, name="a\nerror: b", matrix=[0] * 16)], [0]),
        "big.exr": _exr_header(1000000, 1000000, 2048),
        "hf_etc.toml": '[[object]]\nmesh = "/etc/passwd"\n',
        "hf_up.toml": '[[object]]\nmesh = "../up.obj"\n[[object]]\nprimitive = "plane"\nrole = "receiver"\n',
        "hf_fifo_mesh.toml": '[[object]]\nmesh = "hf_fifo.obj"\n',
        "hf_zero_mesh.toml": '[[object]]\nmesh = "/dev/zero"\n',
        "hf_link_mesh.toml": '[[object]]\nmesh = "hf_link.obj"\n[[object]]\nprimitive = "plane"\nrole = "receiver"\n',
        "hf_sphere_cap.toml": '[[object]]\nprimitive = "sphere"\nsegments = 4096\nrings = 4096\n',
    }
    for label, uri in [("dotdot", "../tri.bin"), ("pct", "%2e%2e/tri.bin"), ("abs", "/etc/passwd"),
                       ("fileuri", "file:///etc/passwd"), ("link", "hf_link.bin"),
                       ("zero", "/dev/zero"), ("urandom", "/dev/urandom"), ("fifo", "hf_fifo.bin"),
                       ("http", "http://example.com/x.bin")]:
        out[f"hf_buf_{label}.gltf"] = _gltf([ground], [0], buffer_uri=uri)
    return {k: v.encode("latin-1") if isinstance(v, str) else v for k, v in out.items()}


def prepare_hostile_files(folder):
    global _HOSTILE_CACHE
    if _HOSTILE_CACHE is None:
        import atexit
        _HOSTILE_CACHE = tempfile.mkdtemp(prefix="softshadow-hostile-files-")
        atexit.register(shutil.rmtree, _HOSTILE_CACHE, True)
        for name, data in hostile_file_inputs().items():
            with open(os.path.join(_HOSTILE_CACHE, name), "wb") as fh:
                fh.write(data)
    for name in os.listdir(_HOSTILE_CACHE):
        os.link(os.path.join(_HOSTILE_CACHE, name), os.path.join(folder, name))
    for fifo in ("hf_fifo.toml", "hf_fifo.obj", "hf_fifo.gltf", "hf_fifo.bin", "hf_fifo.png"):
        os.mkfifo(os.path.join(folder, fifo))
    # Valid files just outside the folder: a scene that reaches them would render.
    parent = os.path.dirname(folder)
    for name, data in (("tri.bin", _tri_buffer(1)), ("up.obj", b"v 0 1 0\nv 1 1 0\nv 0 1 1\nf 1 2 3\n")):
        if not os.path.exists(os.path.join(parent, name)):
            with open(os.path.join(parent, name), "wb") as fh:
                fh.write(data)
    os.symlink(os.path.join(parent, "tri.bin"), os.path.join(folder, "hf_link.bin"))
    os.symlink(os.path.join(parent, "up.obj"), os.path.join(folder, "hf_link.obj"))


def hostile_file_cases():
    """(label, args, env) for every hostile input file."""
    r = ["render"] + SMALL + ["--technique", "hard", "--out", "o.png"]
    out = []
    scenes = sorted(n for n in hostile_file_inputs() if n.startswith("hf_") and n.endswith((".gltf", ".toml")))
    scenes += ["hf_fifo.toml", "hf_fifo.obj", "hf_fifo.gltf", "/dev/zero", "/dev/urandom", "no\nsuch.toml"]
    for f in scenes:
        out.append((f"render --scene {f!r}", r + ["--scene", f], {}))
    for f in ("hf_etc.toml", "hf_buf_abs.gltf", "hf_buf_zero.gltf", "hf_buf_urandom.gltf", "hf_zero_mesh.toml"):
        out.append((f"render --scene {f} --allow-outside-paths", r + ["--scene", f, "--allow-outside-paths"], {}))
    for f in ("hf_chain.gltf", "hf_twice_bare.gltf", "hf_many.gltf", "hf_buf_fileuri.gltf"):
        out.append((f"bench --scenes {f}", ["bench", "--scenes", f, "--techniques", "hard", "--out", "b"], {}))
        out.append((f"export --scene {f}", ["export", "--scene", f, "--obj", "o.obj"], {}))
    out.append(("compare --scene hf_fifo.toml", ["compare", "--reference", "big.exr", "--test", "big.exr",
                                                  "--scene", "hf_fifo.toml"], {}))
    out.append(("compare 1e6 x 1e6 EXR", ["compare", "--reference", "big.exr", "--test", "big.exr",
                                          "--light", "0,5,0"], {}))
    out.append(("compare FIFO PNG", ["compare", "--reference", "big.exr", "--test", "big.exr", "--light", "0,5,0",
                                     "--reference-image", "hf_fifo.png", "--test-image", "hf_fifo.png",
                                     "--out", "c.png"], {}))
    return out


def main():
    exe = binary()
    base = tempfile.mkdtemp(prefix="softshadow-hostile-")
    all_cases = cases(exe) + output_cases(exe)
    counts = {"inputs": len(all_cases), "clean": 0, "exit 0": 0, "error lines != 1": 0,
              "panic or signal": 0, "validation": 0, "left files": 0, "timeout": 0,
              "refused after opening the device": 0}
    failures = []
    for i, (label, args, env) in enumerate(all_cases):
        folder = os.path.join(base, str(i))
        os.mkdir(folder)
        prepare(folder)
        before = snapshot(folder)
        full_env = dict(os.environ)
        full_env.pop("SOFTSHADOW_DEVICE", None)
        full_env.update({k: os.path.join(folder, v) if not v.startswith("/") else v for k, v in env.items()})
        full_env["SOFTSHADOW_CACHE"] = os.path.join(base, "cache")
        try:
            p = subprocess.run([exe] + args + ["--validation"], cwd=folder, env=full_env,
                               capture_output=True, timeout=300)
        except subprocess.TimeoutExpired:
            counts["timeout"] += 1
            failures.append((label, "timeout"))
            continue
        stderr = p.stderr.decode("utf-8", "replace")
        problems = []
        if p.returncode == 0:
            problems.append("exit 0")
        if p.returncode < 0 or "panicked" in stderr:
            problems.append("panic or signal")
        if "validation" in stderr.lower() and "VUID" in stderr:
            problems.append("validation")
        if sum(1 for line in stderr.splitlines() if line.startswith("error")) != 1:
            problems.append("error lines != 1")
        if snapshot(folder) != before:
            problems.append("left files")
        if len(stderr) > 4000:
            problems.append("error lines != 1")
        if label in BEFORE_DEVICE and b"device:" in p.stdout:
            problems.append("refused after opening the device")
        for pr in set(problems):
            counts[pr] += 1
        if problems:
            first = next((l for l in stderr.splitlines() if l.startswith("error")), stderr[:200])
            failures.append((label, ", ".join(sorted(set(problems))) + ": " + first[:200]))
        else:
            counts["clean"] += 1
    checks, extra = interrupt_and_cliff_checks(exe, base)
    counts["inputs"] += checks
    counts["clean"] += checks - len(extra)
    failures += extra
    shutil.rmtree(base, ignore_errors=True)
    for label, why in failures:
        print(f"FAIL {label}: {why}")
    print(" ".join(f"{k}={v}" for k, v in counts.items()))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
