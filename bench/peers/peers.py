#!/usr/bin/env python3
"""Peer renderers on the shared scenes: Mitsuba 3 and LuxCoreRender.

Run through bench/peers/run_peers.sh (it creates the venv). Subcommands, each
meant to run in a process of its own (pyluxcore and mitsuba crash when
imported into one process):

  convert SCENE_XML OUTDIR --resx W --resy H [-D name=value]
      Mitsuba 3 XML -> LuxCore SDL (OUTDIR/scene.scn, PLY meshes, linear EXR
      textures). Pure Python + numpy, except bitmap textures, which are
      decoded sRGB -> linear by a Mitsuba subprocess (`decode-texture`).
  decode-texture IN OUT
      (mitsuba) 8-bit sRGB image -> linear float EXR.
  luxcore SCN OUT.exr --resx W --resy H --time T --threads N --seed S
           --engine PATHCPU|BIDIRCPU --sampler METROPOLIS|SOBOL|RANDOM
           [--max-depth D]
      (pyluxcore) renders for T seconds; prints "RESULT wall_s spp".
  mitsuba SCENE_XML OUT.exr --resx W --resy H --time T --threads N --seed S
          [--max-depth D]
      (mitsuba, scalar_rgb, path) Mitsuba 3 has no time budget: renders
      1 spp to measure the cost of a sample, then spp = T / cost; prints
      "RESULT wall_s spp" of that render. With --threads 1 it hung
      (Mitsuba 3.9.1 here, after the 1 spp render); use 2 or more.
  check SCENE_XML --reference REF.exr --resx W --resy H [--time 30]
        [--seeds 8] [--threads 1] [--sampler RANDOM] [--json FILE]
      The conversion check: converts the scene, renders it --seeds times
      with LuxCore PATHCPU and an unbiased sampler (seeds 0..n-1, each in a
      process of its own), then `check-stats` compares the image means with
      the reference's (box-filtered to W x H, as `cmlt-bench score` does)
      and prints mean/ref per channel with standard errors and whether it
      is within --tolerance (0.02).
  check-stats IMG... --reference REF.exr
      (mitsuba) the statistics of `check` on existing images.

Conversion to LuxCore (what differs and why), checked with `check` against
the reference means (docs/accuracy.md):
  - camera: Mitsuba's to_world matrix -> lookat (origin, origin + z, y up);
    Mitsuba's fov is horizontal (fov_axis x), LuxCore's applies to the
    shorter image side, so it is converted for non-square films. LuxCore
    2.11.2's camera sits one pixel too high (the image content lands one
    row low): the screen window is shifted by --shift-pixels (default -1).
    Measured on veach-bidir at 64x64: relMSE against the reference over
    row shifts -2..2 of the LuxCore image is lowest at 0 with -1 and at -1
    with 0; on veach-ajar at 160x90 LuxCore's ALBEDO output against
    Mitsuba's aov albedo is closest unshifted, over shifts of -1..1 pixel
    in x and y.
  - film: box filter of width 0.5 (one pixel, like the references' box
    rfilter); output RGB (linear, before the image pipeline).
  - max_depth: PATHCPU's path.pathdepth.total = N keeps paths of up to N
    segments (N >= 2), like Mitsuba's max_depth, so N = max_depth
    (measured, see render_luxcore). Russian roulette from depth 5 as
    Mitsuba's rr_depth.
  - diffuse -> matte (kd = rgb, or an imagemap of the linearised bitmap,
    gamma 1); twosided is LuxCore's default for these materials. OBJ
    texture coordinates get Mitsuba's v -> 1 - v.
  - roughconductor -> metal2 with the scene's n, k and u/vroughness =
    alpha. metal2's microfacet distribution (Schlick's, D = r / (pi (1 +
    (r - 1) cos^2)^2) with r = uroughness * vroughness) is GGX's D with
    alpha = uroughness; its shadowing term and its conductor Fresnel
    formula are LuxCore's own approximations, not the exact ones, and
    differ with the angle: on veach-ajar the rough aluminium floor renders
    about 6% low in red and 4% high in blue against the reference. A
    textured specular_reflectance (veach-ajar's checkerboard floor) becomes
    a mix material: the checkerboard weighs the metal2 against a black
    matte, f = spec * f_metal2, Mitsuba's scaling of the Fresnel term.
  - dielectric -> glass (interior IOR int_ior, exterior ext_ior).
  - area emitters -> the shape's material with `emission` = radiance,
    gain 1, power/efficiency 0 (radiance as given); one-sided, on the side
    of the shape's normal, as Mitsuba.
  - shapes: obj (triangles; flat shading with face_normals), rectangle,
    cube, sphere (tessellated, 64 x 32), all transformed to world space
    into binary PLY files (uv as s, t: LuxCore ignores u, v).
"""
import argparse
import math
import os
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))


# ---------------------------------------------------------------- Mitsuba XML


def parse_values(text):
    return [float(v) for v in re.split(r"[,\s]+", text.strip()) if v]


class MitsubaScene:
    """The subset of Mitsuba 3 XML the shared scenes use (tests/scenes/README.md)."""

    def __init__(self, path, defines):
        self.dir = os.path.dirname(os.path.abspath(path))
        root = ET.parse(path).getroot()
        self.defaults = {}
        for d in root.findall("default"):
            self.defaults[d.get("name")] = d.get("value")
        self.defaults.update(defines)
        self.root = root
        self.bsdfs = {b.get("id"): b for b in root.findall("bsdf")}

    def value(self, text):
        return re.sub(r"\$(\w+)", lambda m: self.defaults[m.group(1)], text)

    def prop(self, elem, tag, name, default=None):
        for c in elem.findall(tag):
            if c.get("name") == name:
                return self.value(c.get("value"))
        return default

    def transform(self, elem, name="to_world"):
        m = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
        for t in elem.findall("transform"):
            if t.get("name") != name:
                continue
            for op in t:
                if op.tag == "matrix":
                    v = parse_values(op.get("value"))
                    a = [v[4 * i:4 * i + 4] for i in range(4)]
                elif op.tag == "scale":
                    if op.get("value") is not None:
                        s = [float(op.get("value"))] * 3
                    else:
                        s = [float(op.get(k, "1")) for k in "xyz"]
                    a = [[s[0], 0, 0, 0], [0, s[1], 0, 0], [0, 0, s[2], 0], [0, 0, 0, 1]]
                elif op.tag == "translate":
                    d = [float(op.get(k, "0")) for k in "xyz"]
                    a = [[1, 0, 0, d[0]], [0, 1, 0, d[1]], [0, 0, 1, d[2]], [0, 0, 0, 1]]
                else:
                    raise SystemExit(f"unsupported transform op <{op.tag}>")
                m = matmul(a, m)
        return m


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def apply_point(m, p):
    return [sum(m[i][k] * p[k] for k in range(3)) + m[i][3] for i in range(3)]


def det3(m):
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


# ------------------------------------------------------------------- geometry


def load_obj(path):
    import numpy as np
    vs, vts, faces = [], [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vs.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("vt "):
                vts.append([float(x) for x in line.split()[1:3]])
            elif line.startswith("f "):
                idx = []
                for tok in line.split()[1:]:
                    parts = tok.split("/")
                    vi = int(parts[0]) - 1
                    ti = int(parts[1]) - 1 if len(parts) > 1 and parts[1] else -1
                    idx.append((vi, ti))
                for i in range(1, len(idx) - 1):
                    faces.append((idx[0], idx[i], idx[i + 1]))
    # Unweld: one vertex per face corner (uvs are per corner in OBJ).
    pos = np.array([[vs[v] for v, _ in f] for f in faces], dtype=np.float64).reshape(-1, 3)
    if vts:
        # Mitsuba flips OBJ v on load (flip_tex_coords: v -> 1 - v) and
        # looks up bitmaps with row 0 at v = 0; LuxCore's imagemap lookup
        # has row 0 at v = 0 too, so it wants the same flipped v. (With
        # the unflipped v, veach-ajar's painting and door rendered upside
        # down: compare the ALBEDO output with Mitsuba's aov albedo.)
        uv = np.array([[vts[t] if t >= 0 else [0, 0] for _, t in f] for f in faces],
                      dtype=np.float64).reshape(-1, 2)
        uv[:, 1] = 1.0 - uv[:, 1]
    else:
        uv = None
    return pos, uv


def rectangle():
    import numpy as np
    pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 0], [1, 1], [0, 1]], float)
    return pos, uv


def cube():
    import numpy as np
    tris = []
    for axis in range(3):
        for sign in (-1, 1):
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            quad = []
            for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
                p = [0, 0, 0]
                p[axis], p[u], p[v] = sign, a, b
                quad.append(p)
            if sign < 0:
                quad.reverse()
            tris += [quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]
    return np.array(tris, float), None


def sphere(center, radius, nu=64, nv=32):
    import numpy as np
    def p(i, j):
        th, ph = math.pi * j / nv, 2 * math.pi * i / nu
        return [center[0] + radius * math.sin(th) * math.cos(ph),
                center[1] + radius * math.sin(th) * math.sin(ph),
                center[2] + radius * math.cos(th)]
    tris = []
    for j in range(nv):
        for i in range(nu):
            a, b, c, d = p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)
            tris += [a, c, b, a, d, c]
    return np.array(tris, float), None


def write_ply(path, pos, uv):
    import numpy as np
    n = len(pos)
    cols = [pos.astype(np.float32)]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {n}",
              "property float x", "property float y", "property float z"]
    if uv is not None:
        cols.append(uv.astype(np.float32))
        # LuxCore's PLY reader takes texture coordinates as s, t: with u, v
        # veach-ajar rendered untextured (every lookup at uv = 0).
        header += ["property float s", "property float t"]
    header += [f"element face {n // 3}", "property list uchar int vertex_indices", "end_header"]
    verts = np.concatenate(cols, axis=1)
    faces = np.zeros(n // 3, dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = np.arange(n, dtype=np.int32).reshape(-1, 3)
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode())
        f.write(verts.astype("<f4").tobytes())
        f.write(faces.tobytes())


# ------------------------------------------------------------------ convert


def fmt(v):
    return " ".join(f"{x:.9g}" for x in v)


def convert(args):
    import numpy as np
    defines = dict(d.split("=", 1) for d in args.define)
    sc = MitsubaScene(args.scene, defines)
    os.makedirs(args.out, exist_ok=True)
    lines = []
    tex_count = [0]

    def texture(elem, name):
        """A LuxCore texture or colour for property `name` of a BSDF."""
        for c in elem:
            if c.get("name") != name:
                continue
            if c.tag == "rgb":
                return fmt(parse_values(sc.value(c.get("value"))))
            if c.tag == "float":
                return fmt([float(sc.value(c.get("value")))] * 3)
            if c.tag == "texture" and c.get("type") == "bitmap":
                src = os.path.join(sc.dir, sc.prop(c, "string", "filename"))
                tex_count[0] += 1
                t = f"tex{tex_count[0]}"
                exr = os.path.join(args.out, f"{t}.exr")
                if not os.path.exists(exr):
                    subprocess.run([sys.executable, __file__, "decode-texture", src, exr], check=True)
                lines.append(f'scene.textures.{t}.type = "imagemap"')
                lines.append(f'scene.textures.{t}.file = "{exr}"')
                lines.append(f"scene.textures.{t}.gamma = 1")
                lines.append(f'scene.textures.{t}.filter = "linear"')
                return t
            if c.tag == "texture" and c.get("type") == "checkerboard":
                tex_count[0] += 1
                t = f"tex{tex_count[0]}"
                m = sc.transform(c, "to_uv")
                c0 = parse_values(sc.prop(c, "rgb", "color0"))
                c1 = parse_values(sc.prop(c, "rgb", "color1"))
                # LuxCore's checkerboard2d: tex1 where floor(u) + floor(v) is
                # even. Mitsuba's: color0 where (frac(u') > .5) == (frac(v') >
                # .5), u' = to_uv · uv, i.e. a checker of period 1 in u' with
                # cells of 1/2: scale uv by 2·to_uv and start on color0.
                lines.append(f'scene.textures.{t}.type = "checkerboard2d"')
                lines.append(f"scene.textures.{t}.texture1 = {fmt(c0)}")
                lines.append(f"scene.textures.{t}.texture2 = {fmt(c1)}")
                lines.append(f'scene.textures.{t}.mapping.type = "uvmapping2d"')
                lines.append(f"scene.textures.{t}.mapping.uvscale = {2 * m[0][0]:.9g} {-2 * m[1][1]:.9g}")
                return t
            raise SystemExit(f"unsupported texture {c.tag} {c.get('type')} for {name}")
        return None

    def material(name, bsdf, emission=None):
        if bsdf.get("type") == "twosided":
            bsdf = bsdf.find("bsdf")
        p = f"scene.materials.{name}"
        t = bsdf.get("type")
        if t == "diffuse":
            lines.append(f'{p}.type = "matte"')
            lines.append(f"{p}.kd = {texture(bsdf, 'reflectance') or '0.5 0.5 0.5'}")
        elif t == "roughconductor":
            alpha = float(sc.prop(bsdf, "float", "alpha", "0.1"))
            eta = parse_values(sc.prop(bsdf, "rgb", "eta"))
            k = parse_values(sc.prop(bsdf, "rgb", "k"))
            spec = texture(bsdf, "specular_reflectance")
            if spec is None or spec.replace(" ", "") == "111":
                metal = p
            else:
                # Mitsuba scales the conductor's Fresnel term by
                # specular_reflectance. metal2 cannot scale its Fresnel
                # term (a fresnelcolor texture fitted to spec · F0 is a
                # different conductor: on veach-ajar's floor it reflects
                # 30% more at normal incidence in the dark checker cells
                # and tends to 1 at grazing angles), so the material is a
                # mix of the unscaled metal2 (weight spec) and a black
                # matte (weight 1 − spec): f = spec · f_metal2, exactly
                # Mitsuba's scaling. spec must be grey (a scalar weight).
                if not spec.startswith("tex") and len(set(spec.split())) > 1:
                    raise SystemExit(f"coloured specular_reflectance {spec} not supported")
                metal, black = f"{p}metal", f"{p}black"
                lines.append(f'{black}.type = "matte"')
                lines.append(f"{black}.kd = 0 0 0")
            lines.append(f'{metal}.type = "metal2"')
            lines.append(f"{metal}.n = {fmt(eta)}")
            lines.append(f"{metal}.k = {fmt(k)}")
            lines.append(f"{metal}.uroughness = {alpha:.9g}")
            lines.append(f"{metal}.vroughness = {alpha:.9g}")
            if metal != p:
                lines.append(f'{p}.type = "mix"')
                lines.append(f"{p}.material1 = {name}black")
                lines.append(f"{p}.material2 = {name}metal")
                lines.append(f"{p}.amount = {spec}")
        elif t == "dielectric":
            lines.append(f'{p}.type = "glass"')
            lines.append(f"{p}.kr = 1 1 1")
            lines.append(f"{p}.kt = 1 1 1")
            lines.append(f"{p}.interiorior = {float(sc.prop(bsdf, 'float', 'int_ior', '1.5')):.9g}")
            lines.append(f"{p}.exteriorior = {float(sc.prop(bsdf, 'float', 'ext_ior', '1')):.9g}")
        else:
            raise SystemExit(f"unsupported bsdf {t}")
        if emission is not None:
            lines.append(f"{p}.emission = {fmt(emission)}")
            lines.append(f"{p}.emission.gain = 1 1 1")
            lines.append(f"{p}.emission.power = 0")
            lines.append(f"{p}.emission.efficency = 0")
            lines.append(f"{p}.emission.normalizebycolor = 0")

    # Camera.
    sensor = sc.root.find("sensor")
    m = sc.transform(sensor)
    origin = [m[i][3] for i in range(3)]
    fwd = [m[i][2] for i in range(3)]
    up = [m[i][1] for i in range(3)]
    w, h = args.resx, args.resy
    fov = float(sc.prop(sensor, "float", "fov"))
    axis = sc.prop(sensor, "string", "fov_axis", "x")
    if axis != "x":
        raise SystemExit(f"fov_axis {axis} not supported")
    # LuxCore's fieldofview spans the shorter side.
    if w > h:
        fov = 2 * math.degrees(math.atan(math.tan(math.radians(fov) / 2) * h / w))
    aspect = w / h
    sw = [-aspect, aspect, -1.0, 1.0] if w >= h else [-1.0, 1.0, -1 / aspect, 1 / aspect]
    # One pixel is 2/min(w, h) screen units; LuxCore renders one pixel too
    # high, so the window moves by args.shift_pixels pixels.
    px = 2.0 / min(w, h)
    sw[2] += args.shift_pixels * px
    sw[3] += args.shift_pixels * px
    # Mitsuba's camera has +x to the image's left; LuxCore's lookat camera
    # has the image's right at fwd × up in a right-handed frame — the same
    # world direction as Mitsuba's −x when to_world is a rotation.
    lines.append('scene.camera.type = "perspective"')
    lines.append(f"scene.camera.lookat.orig = {fmt(origin)}")
    lines.append(f"scene.camera.lookat.target = {fmt([o + f for o, f in zip(origin, fwd)])}")
    lines.append(f"scene.camera.up = {fmt(up)}")
    lines.append(f"scene.camera.fieldofview = {fov:.9g}")
    lines.append(f"scene.camera.screenwindow = {fmt(sw)}")

    # Shapes.
    for i, shape in enumerate(sc.root.findall("shape")):
        name = f"shape{i}"
        t = shape.get("type")
        tm = sc.transform(shape)
        if t == "obj":
            pos, uv = load_obj(os.path.join(sc.dir, sc.prop(shape, "string", "filename")))
        elif t == "rectangle":
            pos, uv = rectangle()
        elif t == "cube":
            pos, uv = cube()
        elif t == "sphere":
            c = shape.find("point")
            center = [float(c.get(k, "0")) for k in "xyz"] if c is not None else [0, 0, 0]
            pos, uv = sphere(center, float(sc.prop(shape, "float", "radius", "1")))
        else:
            raise SystemExit(f"unsupported shape {t}")
        pos = np.array([apply_point(tm, p) for p in pos])
        if det3(tm) < 0:
            # A mirroring transform flips the winding; Mitsuba's normal is
            # the transformed normal, so restore the winding.
            pos = pos.reshape(-1, 3, 3)[:, ::-1].reshape(-1, 3)
            if uv is not None:
                uv = uv.reshape(-1, 3, 2)[:, ::-1].reshape(-1, 2)
        ply = os.path.join(args.out, f"{name}.ply")
        write_ply(ply, pos, uv)
        ref = shape.find("ref")
        bsdf = sc.bsdfs[ref.get("id")] if ref is not None else shape.find("bsdf")
        em = shape.find("emitter")
        emission = parse_values(sc.prop(em, "rgb", "radiance")) if em is not None else None
        material(f"mat{i}", bsdf, emission)
        lines.append(f'scene.objects.{name}.ply = "{ply}"')
        lines.append(f"scene.objects.{name}.material = mat{i}")
    # Path depth (LuxCore counts bounces, Mitsuba segments).
    depth = int(sc.value(sc.prop(sc.root.find("integrator"), "integer", "max_depth", "-1")))
    with open(os.path.join(args.out, "scene.scn"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "depth.txt"), "w") as f:
        f.write(f"{depth}\n")
    print(f"wrote {args.out}/scene.scn ({len(sc.root.findall('shape'))} shapes, max_depth {depth})")


def decode_texture(args):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    b = mi.Bitmap(args.src).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    b.write(args.dst)


# -------------------------------------------------------------------- render


def render_luxcore(args):
    import pyluxcore
    pyluxcore.Init(lambda msg: None)
    scn_dir = os.path.dirname(os.path.abspath(args.scn))
    depth = args.max_depth or int(open(os.path.join(scn_dir, "depth.txt")).read())
    # PATHCPU's path.pathdepth.total = N keeps paths of up to N segments
    # for N >= 2 (no direct light sampling at the last vertex, see
    # slg PathTracer::RenderEyePath), the same count as Mitsuba's
    # max_depth; measured: cornell-box 64x64 at N = 2 and 3 matches
    # Mitsuba's max_depth 2 and 3 within 0.2%, N = 2 is 11-16% below
    # max_depth 3 (docs/accuracy/luxcore-depth-check.txt). (N = 1 would also add
    # direct lighting; Mitsuba's max_depth 1 has no LuxCore equivalent.)
    # BIDIRCPU's path.maxdepth / light.maxdepth keep max_depth - 1
    # (unchecked; BIDIRCPU is biased anyway, see docs/accuracy.md).
    if depth < 2:
        raise SystemExit(f"max_depth {depth}: no LuxCore equivalent (needs >= 2)")
    lux_depth = depth
    props = pyluxcore.Properties()
    props.SetFromString(f"""
renderengine.type = "{args.engine}"
sampler.type = "{args.sampler}"
renderengine.seed = {args.seed + 1}
native.threads.count = {args.threads}
film.width = {args.resx}
film.height = {args.resy}
film.filter.type = "BOX"
film.filter.width = 0.5
film.outputs.0.type = "RGB"
film.outputs.0.filename = "{args.out}"
film.imagepipelines.0.0.type = "TONEMAP_LINEAR"
film.imagepipelines.0.0.scale = 1
path.russianroulette.depth = 5
light.maxdepth = {max(depth - 1, 1)}
path.maxdepth = {max(depth - 1, 1)}
path.pathdepth.total = {lux_depth}
path.pathdepth.diffuse = {lux_depth}
path.pathdepth.glossy = {lux_depth}
path.pathdepth.specular = {lux_depth}
path.clamping.variance.maxvalue = 0
batch.halttime = {args.time}
scene.file = "{os.path.abspath(args.scn)}"
""")
    config = pyluxcore.RenderConfig(props)
    session = pyluxcore.RenderSession(config)
    t0 = time.perf_counter()
    session.Start()
    while not session.HasDone():
        time.sleep(0.02)
        session.UpdateStats()
    wall = time.perf_counter() - t0
    session.Stop()
    film = session.GetFilm()
    film.SaveOutputs()
    stats = session.GetStats()
    spp = stats.Get("stats.renderengine.pass").GetFloat()
    print(f"RESULT {wall:.4f} {spp:.3f}", flush=True)
    # pyluxcore 2.11.2 segfaults while tearing down after a METROPOLIS
    # render; everything is written by now, so skip the teardown.
    os._exit(0)


def render_mitsuba(args):
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    dr.set_thread_count(args.threads)
    extra = {"max_depth": args.max_depth} if args.max_depth else {}
    scene = mi.load_file(args.scene, resx=args.resx, resy=args.resy, integrator="path", **extra)
    # Mitsuba 3 has no time budget: time one sample per pixel (after a
    # warm-up render), then render the spp that fills the budget.
    mi.render(scene, spp=1, seed=10_000 + args.seed)
    t = time.perf_counter()
    mi.render(scene, spp=2, seed=20_000 + args.seed)
    per_spp = (time.perf_counter() - t) / 2
    spp = max(1, int(args.time / per_spp))
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=args.seed)
    wall = time.perf_counter() - t
    mi.Bitmap(img).write(args.out)
    print(f"RESULT {wall:.4f} {spp}")



# --------------------------------------------------------------------- check


def load_exr(path):
    import mitsuba as mi
    import numpy as np
    b = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(b, dtype=np.float64)


def box_down(img, w, h):
    """The reference box-filtered to w x h (integer factor), as
    `cmlt-bench score` does (Image::downsample)."""
    H, W, _ = img.shape
    f = W // w
    if f * w != W or f * h != H:
        raise SystemExit(f"reference {W}x{H} is not an integer multiple of {w}x{h}")
    return img.reshape(h, f, w, f, 3).mean(axis=(1, 3))


def check_stats(args):
    """(mitsuba) Image means of independent renders against the reference's.

    Standard errors (per channel, of mean/ref):
      seeds  - across the renders' means: std / sqrt(n);
      pixels - from the per-pixel spread across the renders (pixels are
               independent for a non-Metropolis sampler): sqrt(sum of
               per-pixel variances / n) / pixels;
      ref    - the reference's own, from its two independent halves
               (reference_half0/1.exr next to it, if present): half the
               pixel-based standard error of their difference's mean.
    The combined standard error of the ratio uses the larger of the two
    render estimates and the reference's, in quadrature."""
    import json
    import numpy as np
    ref_path = os.path.abspath(args.reference)
    ref = load_exr(ref_path)
    H, W, _ = ref.shape
    imgs = np.array([load_exr(p) for p in args.images])
    n, h, w, _ = imgs.shape
    rm = box_down(ref, w, h).reshape(-1, 3).mean(0)
    means = imgs.reshape(n, -1, 3).mean(1)
    ratios = means / rm
    ratio = ratios.mean(0)
    se_seeds = ratios.std(0, ddof=1) / math.sqrt(n) if n > 1 else np.full(3, np.nan)
    if n > 1:
        var_pix = imgs.reshape(n, -1, 3).var(0, ddof=1)
        se_pix = np.sqrt(var_pix.sum(0) / n) / (h * w) / rm
    else:
        se_pix = np.full(3, np.nan)
    se_ref = np.full(3, np.nan)
    halves = [os.path.join(os.path.dirname(ref_path), f"reference_half{i}.exr") for i in (0, 1)]
    if all(os.path.exists(p) for p in halves):
        d = (load_exr(halves[0]) - load_exr(halves[1])).reshape(-1, 3)
        se_ref = 0.5 * np.sqrt(d.var(0, ddof=1) / len(d)) / rm * ratio
    else:
        print("(no reference_half0/1.exr next to the reference: its own error is not included)")
    se_render = np.fmax(np.nan_to_num(se_seeds), np.nan_to_num(se_pix))
    se = np.sqrt(se_render ** 2 + np.nan_to_num(se_ref) ** 2) if n > 1 else np.full(3, np.nan)
    f3 = lambda v: " ".join(f"{x:.4f}" if np.isfinite(x) else "n/a" for x in v)
    print(f"reference {args.reference} ({W}x{H} box-filtered to {w}x{h}): mean {f3(rm)}")
    for p, m, r in zip(args.images, means, ratios):
        print(f"  {p}: mean {f3(m)}  mean/ref {f3(r)}")
    # Where a mismatch sits: mean/ref of the renders' mean in 5 bands of
    # rows, top to bottom.
    refd = box_down(ref, w, h)
    avg = imgs.mean(0)
    for b in range(5):
        rows = slice(b * h // 5, (b + 1) * h // 5)
        br = avg[rows].reshape(-1, 3).mean(0) / refd[rows].reshape(-1, 3).mean(0)
        print(f"  rows {rows.start}-{rows.stop - 1}: mean/ref {f3(br)}")
    print(f"mean/ref over {n} renders (R G B): {f3(ratio)}")
    print(f"  standard error: seeds {f3(se_seeds)}, pixels {f3(se_pix)}, reference {f3(se_ref)}")
    print(f"  combined        {f3(se)}")
    worst = np.abs(ratio - 1) + 2 * np.nan_to_num(se)
    ok = bool(np.all(np.abs(ratio - 1) < args.tolerance))
    print(f"|mean/ref - 1| < {args.tolerance:g} in every channel: {'yes' if ok else 'NO'}"
          f" (|mean/ref - 1| + 2 SE: {f3(worst)})")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"images": args.images, "ref_mean": rm.tolist(), "means": means.tolist(),
                       "ratio": ratio.tolist(), "se_seeds": se_seeds.tolist(), "se_pixels": se_pix.tolist(),
                       "se_ref": se_ref.tolist(), "se": se.tolist(), "ok": ok}, f, indent=1)


def check(args):
    """Converts SCENE_XML, renders it with LuxCore --seeds times (each in a
    process of its own, seeds 0..n-1) and compares the image means with the
    reference (check-stats, in a Mitsuba process)."""
    name = os.path.basename(os.path.dirname(os.path.abspath(args.scene)))
    work = os.path.join(args.work, f"check-{name}-{args.resx}x{args.resy}")
    me = os.path.relpath(__file__)
    defines = [x for d in args.define for x in ("-D", d)]
    subprocess.run([sys.executable, me, "convert", args.scene, work, "--resx", str(args.resx),
                    "--resy", str(args.resy), *defines], check=True)
    imgs = []
    for seed in range(args.seeds):
        img = os.path.join(work, f"{args.engine.lower()}-{args.sampler.lower()}-{args.time:g}s-seed{seed}.exr")
        out = subprocess.run([sys.executable, me, "luxcore", os.path.join(work, "scene.scn"), img,
                              "--resx", str(args.resx), "--resy", str(args.resy), "--time", str(args.time),
                              "--threads", str(args.threads), "--seed", str(seed),
                              "--engine", args.engine, "--sampler", args.sampler],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        res = [l for l in out.stdout.splitlines() if l.startswith("RESULT")]
        if not res:
            raise SystemExit(f"luxcore render failed (seed {seed}, exit {out.returncode})")
        print(f"seed {seed}: {res[0]} -> {img}", flush=True)
        imgs.append(img)
    cmd = [sys.executable, me, "check-stats", "--reference", args.reference,
           "--tolerance", str(args.tolerance), *imgs]
    if args.json:
        cmd += ["--json", args.json]
    subprocess.run(cmd, check=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("convert")
    c.add_argument("scene")
    c.add_argument("out")
    c.add_argument("--resx", type=int, required=True)
    c.add_argument("--resy", type=int, required=True)
    c.add_argument("--shift-pixels", type=float, default=-1.0)
    c.add_argument("-D", dest="define", action="append", default=[])
    d = sub.add_parser("decode-texture")
    d.add_argument("src")
    d.add_argument("dst")
    for name in ("luxcore", "mitsuba"):
        r = sub.add_parser(name)
        r.add_argument("scn" if name == "luxcore" else "scene")
        r.add_argument("out")
        r.add_argument("--resx", type=int, required=True)
        r.add_argument("--resy", type=int, required=True)
        r.add_argument("--time", type=float, required=True)
        r.add_argument("--threads", type=int, default=2)
        r.add_argument("--seed", type=int, default=0)
        # Overrides the scene's max_depth (Mitsuba's meaning).
        r.add_argument("--max-depth", type=int, default=0)
        if name == "luxcore":
            r.add_argument("--engine", default="PATHCPU")
            r.add_argument("--sampler", default="METROPOLIS")
    k = sub.add_parser("check")
    k.add_argument("scene")
    k.add_argument("--reference", required=True)
    k.add_argument("--resx", type=int, required=True)
    k.add_argument("--resy", type=int, required=True)
    k.add_argument("--time", type=float, default=30)
    k.add_argument("--seeds", type=int, default=8)
    k.add_argument("--threads", type=int, default=1)
    k.add_argument("--engine", default="PATHCPU")
    k.add_argument("--sampler", default="RANDOM")
    k.add_argument("--tolerance", type=float, default=0.02)
    k.add_argument("--work", default=os.path.relpath(os.path.join(HERE, "work")))
    k.add_argument("--json")
    k.add_argument("-D", dest="define", action="append", default=[])
    t = sub.add_parser("check-stats")
    t.add_argument("images", nargs="+")
    t.add_argument("--reference", required=True)
    t.add_argument("--tolerance", type=float, default=0.02)
    t.add_argument("--json")
    args = ap.parse_args()
    {"convert": convert, "decode-texture": decode_texture,
     "luxcore": render_luxcore, "mitsuba": render_mitsuba,
     "check": check, "check-stats": check_stats}[args.cmd](args)


if __name__ == "__main__":
    main()
