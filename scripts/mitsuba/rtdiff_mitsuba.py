"""Mitsuba 3 side of rtdiff's image oracle: the reports' Whitted integrator as a Mitsuba plugin,
and a render loop over a scene exported by `rtdiff export SCENE --to mitsuba -o DIR`.

An export is one of two oracles (rtdiff.json "oracle"). A native export uses only Mitsuba's own
emitters, BSDFs and integrators; `load` and `render` then run its recipe (`render_native`: one
`mi.render` per emitter file and BSDF file, summed with the recipe's weights). A plugin export
uses the integrator below.

Mitsuba 3 has no Phong BSDF, no Whitted integrator, no glossy lobe of the reports' kind, no
segment light and no parallelogram light with bilinear corner colours. `rtdiff_whitted`
(registered with `mi.register_integrator`) adds them: it intersects with Mitsuba's
`scene.ray_intersect` / `ray_test` (Embree inside Mitsuba), takes camera rays from Mitsuba's
sensor (`perspective` / `thinlens`), reads the hit point, geometric normal and interpolated
shading normal from Mitsuba's surface interaction, looks up kd through Mitsuba's `diffuse` BSDF and
`bitmap` texture (nearest / bilinear, the material's wrap mode), and draws every random number from Mitsuba's
sampler. Only the reports' model is written here, from the course reports (../shared/seeds/) and
docs/oracles.md, independently of rtdiff's Rust code:

  phong:    sum over light samples of  I * (Kd max(0, n.l) + Ks max(0, r.v)^Ns) / N
  physical: Lambert Kd/pi; point and segment samples I / r^2 (segment: length / N per sample);
            parallelogram samples are radiance with the cosine at both ends (area / N per sample)
  both:     shadow rays (transparent blockers attenuate by 1 - opacity, at most 64 crossings),
            mirror recursion weighted by Ks to max_depth, alpha blending
            opacity * surface + (1 - opacity) * behind;
  glossy:   the mirror direction r perturbed inside a square of side a = 1 / shininess
            perpendicular to r (the orthonormal pair of Duff et al. 2017 around r), du, dv
            uniform in [-a/2, a/2); the average of N such rays at the first bounce (N =
            glossy_samples), one ray per deeper bounce; a ray entering the surface (g.ng <= 0)
            contributes black but counts in N.

Secondary rays leave the surface by the model's spawn rule (docs/oracles.md, "Ray offsets"): the
origin moves along the geometric normal, to the side the new ray goes, by the bound on the
float32 error of the hit point (gamma(7) times the largest vertex coordinate of the triangle;
gamma(6)|p - c| + gamma(5)|c| on a sphere) and one more float32 step away from the surface;
shadow rays end 1e-4 of the way short of the light. Mitsuba's own `spawn_ray` pushes the origin
(1 + max|p|) * 8.9e-5 off the surface instead, which moves the point a grazing mirror ray sees by
up to 1e-2 on a curved mesh (monkey) and is not part of the model. The rule is the model's
contract for where a secondary ray starts, not the renderer under test: the intersections, normals,
camera, textures and samples stay Mitsuba's.

The integrator is a wavefront over Dr.Jit arrays (one lane per pixel): the reports' ray tree is
walked as a stack of nodes (ray, weight, depth), each node shaded for all lanes at once and
evaluated before its children are pushed; the crossings of transparent blockers run in a
symbolic `dr.while_loop`. The render loop (`render`) samples pixel positions the way rtdiff
does: the pixel centre for one sample per pixel, an n x n jittered grid for n*n samples, uniform
otherwise; times lens samples.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def pick_variant(requested: str | None = None) -> str:
    """llvm_ad_rgb when libLLVM 19 is present (libLLVM 15 aborts on some scenes), else scalar_rgb."""
    if requested:
        return requested
    if os.path.exists(LLVM19):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM19)
        return "llvm_ad_rgb"
    return "scalar_rgb"


def setup(variant: str | None = None):
    """Select the Mitsuba variant and register the plugin; returns the mitsuba module.

    With RTDIFF_MITSUBA_ISA=avx2 (set by scripts/mitsuba/as-avx2.sh) Dr.Jit's LLVM backend
    compiles for an AVX2 CPU without AVX-512 (see `emulate_isa`)."""
    variant = pick_variant(variant)
    import mitsuba as mi

    mi.set_variant(variant)
    isa = os.environ.get("RTDIFF_MITSUBA_ISA")
    if isa and variant.startswith("llvm"):
        emulate_isa(mi, isa)
    _register(mi)
    return mi


#: LLVM target CPU standing for each emulated instruction set.
EMULATED_CPUS = {"avx2": ("haswell", 8)}


def emulate_isa(mi, isa: str):
    """Make Dr.Jit's LLVM backend generate code as on a CPU with instruction set `isa` (only
    "avx2": target CPU haswell, 8-wide vectors, every AVX-512, AVX10 and AMX feature of the
    host's list switched off), through drjit-core's `jit_llvm_set_target`, which the Python
    module does not expose. Embree inside Mitsuba picks its own kernels: scripts/mitsuba/as-avx2.sh
    caps those with Embree's `max_isa` option. Prints the target to stderr."""
    import ctypes

    import drjit as dr

    if isa not in EMULATED_CPUS:
        raise ValueError(f"RTDIFF_MITSUBA_ISA={isa!r}: only {sorted(EMULATED_CPUS)} can be emulated")
    cpu, width = EMULATED_CPUS[isa]
    core = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    # C++ linkage: jit_llvm_set_target(const char*, const char*, uint32_t) and its getters.
    set_target = core._Z19jit_llvm_set_targetPKcS0_j
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    get_features = core._Z24jit_llvm_target_featuresv
    get_features.restype = ctypes.c_char_p
    get_cpu = core._Z19jit_llvm_target_cpuv
    get_cpu.restype = ctypes.c_char_p
    get_width = core._Z21jit_llvm_vector_widthv
    get_width.restype = ctypes.c_uint32
    dr.eval(mi.Float(0.0))  # the LLVM backend initialises on first use; the target is set after
    host = (get_features() or b"").decode()
    wide = ("+avx512", "+evex512", "+avx10", "+amx")
    features = ",".join("-" + f[1:] if f.startswith(wide) else f for f in host.split(",") if f)
    set_target(cpu.encode(), features.encode(), width)
    print(f"rtdiff_mitsuba: Dr.Jit LLVM target {get_cpu().decode()}, {get_width()}-wide, AVX-512 off", file=sys.stderr)


def gamma(n: int) -> float:
    """n u / (1 - n u) with u = 2^-24, in float32 (the bound on n chained float32 roundings)."""
    nu = np.float32(n) * np.float32(2.0**-24)
    return float(nu / (np.float32(1.0) - nu))


#: Shadow rays stop this fraction of the way short of the light sample.
SHADOW_T_MAX = 1.0 - 1.0e-4
#: At most this many transparent surfaces crossed by one shadow ray.
MAX_SHADOW_CROSSINGS = 64


def _host3(v, m: int) -> np.ndarray:
    """An evaluated Dr.Jit 3-vector (or colour) of width m (or 1, broadcast) as an (m, 3) float64 array."""
    cols = [np.broadcast_to(np.asarray(c.numpy(), dtype=np.float64), (m,)) for c in (v[0], v[1], v[2])]
    return np.stack(cols, axis=1)


def _seed32(stream: int, depth: int) -> int:
    """A 32-bit sampler seed for (render stream, tree depth): SplitMix64 of both, high half."""
    z = (stream * 0x9E3779B97F4A7C15 + depth * 0xBF58476D1CE4E5B9 + 0x94D049BB133111EB) & (2**64 - 1)
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & (2**64 - 1)
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & (2**64 - 1)
    return (z ^ (z >> 31)) >> 32


def _register(mi):
    import drjit as dr

    scalar = mi.variant().startswith("scalar")

    def step_away(v, n):
        """v moved one float32 step towards +inf where n > 0 and towards -inf where n < 0."""
        if scalar:
            if n == 0:
                return v
            return float(np.nextafter(np.float32(v), np.float32(math.inf if n > 0 else -math.inf)))
        v = dr.select(v == 0.0, 0.0, v)  # -0 -> +0, so that +-0 step to +-the smallest subnormal
        bits = dr.reinterpret_array(mi.Int32, v)
        # For v >= 0 the next float up has bits + 1, for v < 0 bits - 1; down is the mirror image.
        up = dr.reinterpret_array(mi.Float, dr.select(v >= 0.0, bits + 1, bits - 1))
        down = dr.reinterpret_array(mi.Float, dr.select(v > 0.0, bits - 1, bits + 1))
        down = dr.select(v == 0.0, -dr.reinterpret_array(mi.Float, mi.Int32(1)), down)
        return dr.select(n > 0.0, up, dr.select(n < 0.0, down, v))

    def _not(mask):
        """Logical not of a mask (a Python bool in scalar variants, where ~True is -2)."""
        return (not mask) if scalar else ~mask

    class RtdiffWhitted(mi.SamplingIntegrator):
        """The reports' recursive ray tracer (see the module docstring)."""

        def __init__(self, props):
            super().__init__(props)
            path = props.get("config", "rtdiff.json")
            resolved = str(mi.Thread.thread().file_resolver().resolve(path))
            with open(resolved) as f:
                self.cfg = json.load(f)
            if self.cfg.get("format") != "rtdiff-mitsuba-1":
                raise ValueError(f"{resolved}: not an rtdiff export (format {self.cfg.get('format')!r})")
            self.max_depth = int(props.get("max_depth", self.cfg["max_depth"]))
            self.plan = self.cfg["plan"]
            self.mats = self.cfg["materials"]
            self.shape_cfg = {s["id"]: s for s in self.cfg["shapes"]}
            self.lights = self.cfg["lights"]
            self.n_samples = max(int(self.cfg["light_samples"]), 1)
            self.jittered = self.cfg["light_sampling"] == "jittered"
            self.glossy_samples = max(int(self.cfg.get("glossy_samples", 1)), 1)
            self.bg = self.cfg["background"]
            offset = self.cfg.get("ray_offset", {"kind": "robust"})
            # The reports' fixed offset (origin + epsilon * unit direction), when the scene asks for it.
            if offset["kind"] not in ("robust", "fixed", "scaled-normal"):
                raise ValueError(f"{resolved}: unknown ray_offset kind {offset['kind']!r}")
            self.fixed_epsilon = float(offset["epsilon"]) if offset["kind"] == "fixed" else None
            # Mitsuba's own spawn_ray (epsilon (1 + max|p|) along the normal), when the scene asks for it.
            self.scaled_epsilon = float(offset["epsilon"]) if offset["kind"] == "scaled-normal" else None
            self._tables = None

        # --- per-shape tables ---------------------------------------------------------------
        def _prepare(self, scene):
            """Per-shape material and geometry tables, gathered per lane by the shape's registry id."""
            if self._tables is not None:
                return
            shapes = list(scene.shapes())
            rows = []
            face_scale = []
            for s in shapes:
                c = self.shape_cfg[s.id()]
                m = self.mats[c["material"]]
                row = {
                    "ks": m["ks"], "shin": m["shininess"], "opac": m["opacity"],
                    "phys": m["model"] == "physical", "sphere": "center" in c,
                    "center": c.get("center", [0.0, 0.0, 0.0]), "face_base": len(face_scale),
                }
                if not row["sphere"]:
                    params = mi.traverse(s)
                    v = np.array(params["vertex_positions"], dtype=np.float32).reshape(-1, 3)
                    f = np.array(params["faces"], dtype=np.int64).reshape(-1, 3)
                    # gamma(7) times the largest |coordinate| of the triangle's vertices: the
                    # float32 error bound of a point interpolated from them (barycentric weights
                    # sum to 1, so the bound never exceeds this floor).
                    face_scale.extend((np.float32(gamma(7)) * np.abs(v[f]).max(axis=(1, 2))).tolist())
                rows.append(row)
            if scalar:
                self._by_id = {s.id(): r for s, r in zip(shapes, rows)}
                self._face_scale = face_scale
                self._tables = True
                return
            ids = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0]) for s in shapes]
            lut = np.zeros(max(ids) + 1, dtype=np.uint32)
            for k, i in enumerate(ids):
                lut[i] = k
            col = lambda key, j=None: mi.Float([float(r[key] if j is None else r[key][j]) for r in rows])  # noqa: E731
            self._lut = mi.UInt32(lut)
            self._ks = [col("ks", j) for j in range(3)]
            self._shin, self._opac = col("shin"), col("opac")
            self._phys = mi.Bool([r["phys"] for r in rows])
            self._sphere = mi.Bool([r["sphere"] for r in rows])
            self._center = [col("center", j) for j in range(3)]
            self._face_base = mi.UInt32([r["face_base"] for r in rows])
            self._face_scale = mi.Float(face_scale if face_scale else [0.0])
            self._tables = True

        def _params(self, si, active):
            """(ks, shininess, opacity, physical, error bound of si.p) at each lane's hit."""
            if scalar:
                if not active:
                    return mi.Color3f(0.0), 1.0, 1.0, False, mi.Vector3f(0.0)
                r = self._by_id[si.shape.id()]
                if r["sphere"]:
                    c = mi.Vector3f(*r["center"])
                    err = gamma(6) * dr.abs(si.p - c) + gamma(5) * dr.abs(c)
                else:
                    err = mi.Vector3f(self._face_scale[r["face_base"] + si.prim_index])
                return mi.Color3f(*r["ks"]), r["shin"], r["opac"], r["phys"], err
            k = dr.gather(mi.UInt32, self._lut, dr.reinterpret_array(mi.UInt32, si.shape), active)
            g = lambda a: dr.gather(type(a), a, k, active)  # noqa: E731
            ks = mi.Color3f(g(self._ks[0]), g(self._ks[1]), g(self._ks[2]))
            sphere = g(self._sphere)
            c = mi.Vector3f(g(self._center[0]), g(self._center[1]), g(self._center[2]))
            tri = dr.gather(mi.Float, self._face_scale, g(self._face_base) + si.prim_index, active & ~sphere)
            err = dr.select(sphere, gamma(6) * dr.abs(si.p - c) + gamma(5) * dr.abs(c), mi.Vector3f(tri))
            return ks, g(self._shin), g(self._opac), g(self._phys), err

        # --- the spawn rule ---------------------------------------------------------------------
        def _origin(self, p, err, ng, w):
            """Origin of a ray leaving p (error bound err, unit geometric normal ng) towards w."""
            if self.fixed_epsilon is not None:
                return p + self.fixed_epsilon * dr.normalize(w)
            n = dr.select(dr.dot(w, ng) < 0.0, -ng, ng)
            if self.scaled_epsilon is not None:
                return p + self.scaled_epsilon * (1.0 + dr.max(dr.abs(p))) * n
            po = p + dr.dot(dr.abs(n), err) * n
            return mi.Point3f(step_away(po.x, n.x), step_away(po.y, n.y), step_away(po.z, n.z))

        def _spawn(self, p, err, ng, d):
            return mi.Ray3f(self._origin(p, err, ng, d), d)

        def _spawn_to(self, p, err, ng, target):
            o = self._origin(p, err, ng, target - p)
            d = target - o
            dist = dr.norm(d)
            return mi.Ray3f(o, d / dr.maximum(dist, 1e-30), dist * SHADOW_T_MAX, 0.0, mi.Color0f())

        # --- light samples --------------------------------------------------------------------
        def _light_samples(self, sampler, active):
            """Yield (position, colour, average_weight, measure, normal or None, is_point) per sample."""
            n = self.n_samples
            for L in self.lights:
                if L["type"] == "point":
                    yield mi.Point3f(*L["position"]), mi.Color3f(*L["color"]), 1.0, 1.0, None, True
                elif L["type"] == "segment":
                    p0, p1 = mi.Point3f(*L["endpoints"][0]), mi.Point3f(*L["endpoints"][1])
                    c0, c1 = mi.Color3f(*L["colors"][0]), mi.Color3f(*L["colors"][1])
                    length = float(np.linalg.norm(np.subtract(L["endpoints"][1], L["endpoints"][0])))
                    for i in range(n):
                        u = sampler.next_1d(active)
                        t = (i + u) / n if self.jittered else u
                        yield p0 + t * (p1 - p0), (1 - t) * c0 + t * c1, 1.0 / n, length / n, None, False
                else:
                    v0, e1, e2 = (mi.Vector3f(*L[k]) for k in ("v0", "edge01", "edge02"))
                    c = [mi.Color3f(*x) for x in L["colors"]]
                    cross = np.cross(L["edge01"], L["edge02"])
                    area = float(np.linalg.norm(cross))
                    normal = mi.Vector3f(*(cross / area).tolist())
                    if self.jittered:
                        k = math.ceil(math.sqrt(n))
                        cells = [(i, j, k) for i in range(k) for j in range(k)]
                    else:
                        cells = [(0, 0, 1)] * n
                    count = len(cells)
                    for i, j, k in cells:
                        s = sampler.next_2d(active)
                        a, b = (i + s.x) / k, (j + s.y) / k
                        col = (1 - a) * ((1 - b) * c[0] + b * c[2]) + a * ((1 - b) * c[1] + b * c[3])
                        yield mi.Point3f(v0 + a * e1 + b * e2), col, 1.0 / count, area / count, normal, False

        # --- shadow rays ------------------------------------------------------------------------
        def _visibility(self, scene, p, err, ng, target, active):
            """Fraction of light from `target` reaching p: 0/1, attenuated by transparent blockers."""
            ray = self._spawn_to(p, err, ng, target)
            if not self.plan["transparency"]:
                return dr.select(active & scene.ray_test(ray, active), 0.0, 1.0)

            def body(ray, trans, alive, i):
                hit = scene.ray_intersect(ray, alive)
                blocked = alive & hit.is_valid()
                _, _, op, _, herr = self._params(hit, blocked)
                trans = dr.select(blocked, dr.select(op < 1.0, trans * (1.0 - op), 0.0), trans)
                alive = blocked & (op < 1.0)
                hng = mi.Vector3f(hit.n)
                ray = dr.select(alive, self._spawn_to(hit.p, herr, hng, target), ray)
                return ray, trans, alive, i + 1

            ray, trans, alive, _ = dr.while_loop(
                state=(ray, mi.Float(1.0), mi.Bool(active), mi.UInt32(0)),
                cond=lambda ray, trans, alive, i: alive & (i < MAX_SHADOW_CROSSINGS),
                body=body,
                labels=("ray", "trans", "alive", "i"),
            )
            # Still alive after the last crossing: the cap was reached, no light (as the model).
            return dr.select(alive | _not(active), 0.0, trans)

        # --- shading ------------------------------------------------------------------------------
        def _direct(self, scene, sampler, p, err, ng, ns, wo, kd, ks, shin, phys, active):
            total = mi.Color3f(0.0)
            for pos, col, avg_w, measure, normal, is_point in self._light_samples(sampler, active):
                if not is_point and not self.plan["area_lights"]:
                    continue
                shadows = self.plan["hard_shadows"] if is_point else self.plan["soft_shadows"]
                d = pos - p
                r2 = dr.squared_norm(d)
                l = d * dr.rsqrt(dr.maximum(r2, 1e-30))
                ndl = dr.dot(ns, l)
                lit = active & (ndl > 0.0) & (r2 > 0.0)
                # Phong (the reports): I (Kd n.l + Ks max(0, r.v)^Ns) / N, no falloff.
                r = 2.0 * ndl * ns - l
                rdv = dr.dot(r, wo)
                spec = dr.select(rdv > 0.0, ks * dr.power(dr.maximum(rdv, 1e-30), shin), 0.0)
                spec = dr.select(dr.all(ks == 0.0), 0.0, spec)
                phong = col * (kd * ndl + spec) * avg_w
                # Physical: Kd/pi * I * cos * cos_light * measure / r^2.
                cos_light = 1.0 if normal is None else dr.maximum(dr.dot(-l, normal), 0.0)
                physical = kd * dr.inv_pi * col * (ndl * cos_light * measure / r2)
                f = dr.select(phys, physical, phong)
                f = dr.select(lit, f, 0.0)
                if shadows:
                    f = f * self._visibility(scene, p, err, ng, pos, lit & dr.any(f != 0.0))
                total += f
            return total

        def _glossy_directions(self, sampler, r, shin, depth, active):
            """The reports' glossy rays around r: (direction, weight / N) pairs, N rays at depth 0."""
            n = self.glossy_samples if depth == 0 else 1
            # Duff et al. 2017, "Building an orthonormal basis, revisited" (listing 3).
            sign = dr.copysign(1.0, r.z)  # glam's signum: -0 counts as negative
            a0 = -1.0 / (sign + r.z)
            b0 = r.x * r.y * a0
            u = mi.Vector3f(1.0 + sign * r.x * r.x * a0, sign * b0, -sign * r.x)
            w = mi.Vector3f(b0, sign + r.y * r.y * a0, -r.y)
            a = 1.0 / dr.maximum(shin, 1.1754944e-38)
            for _ in range(n):
                s = sampler.next_2d(active)
                g = dr.normalize(r + (s.x - 0.5) * a * u + (s.y - 0.5) * a * w)
                yield g, 1.0 / n

        def _shade(self, scene, sampler, ray, weight, depth, active):
            """Shade one node of the ray tree for every lane: (contribution, children), each child
            (ray, weight, mask)."""
            si = scene.ray_intersect(ray, active)
            valid = active & si.is_valid()
            miss = dr.select(active & _not(valid), weight * mi.Color3f(*self.bg), 0.0)
            if scalar and not valid:
                return miss, []  # no surface to ask for a BSDF (a null shape in scalar mode)
            d = dr.normalize(ray.d)
            ng = mi.Vector3f(si.n)
            ns = mi.Vector3f(si.sh_frame.n)
            # Two-sided shading: both normals on the side the ray came from.
            ng = dr.select(dr.dot(ng, d) > 0.0, -ng, ng)
            ns = dr.select(dr.dot(ns, ng) < 0.0, -ns, ns)
            ks, shin, opac, phys, err = self._params(si, valid)
            bsdf = si.bsdf(ray)
            kd = mi.Color3f(bsdf.eval_diffuse_reflectance(si, valid))
            if self.plan["shading"]:
                color = self._direct(scene, sampler, si.p, err, ng, ns, -d, kd, ks, shin, phys, valid)
            else:
                color = kd
            deeper = depth < self.max_depth
            blend = valid & (opac < 1.0) if (self.plan["transparency"] and deeper) else mi.Bool(False)
            w_here = weight * dr.select(blend, opac, 1.0)
            contribution = miss + dr.select(valid, w_here * color, 0.0)
            children = []
            if self.plan["reflections"] and deeper:
                refl = valid & dr.any(ks != 0.0)
                r = dr.normalize(d - 2.0 * dr.dot(d, ns) * ns)
                if self.plan["glossy"]:
                    for g, share in self._glossy_directions(sampler, r, shin, depth, refl):
                        ok = refl & (dr.dot(g, ng) > 0.0)  # a ray into the surface sees no light
                        children.append((self._spawn(si.p, err, ng, g), w_here * ks * share, ok))
                else:
                    children.append((self._spawn(si.p, err, ng, r), w_here * ks, refl))
            if self.plan["transparency"] and deeper:
                children.append((self._spawn(si.p, err, ng, d), weight * (1.0 - opac), blend))
            return contribution, children

        def set_pass_seed(self, seed: int):
            """Seed of the samplers this integrator forks for secondary rays (one per render pass)."""
            self.pass_seed = int(seed)

        def sample(self, scene, sampler, ray, medium=None, active=True):
            self._prepare(scene)
            if scalar:
                return self._sample_scalar(scene, sampler, ray, active)
            # Wavefront: every ray of one depth of the tree in one array (rays of one pixel may
            # be several: glossy samples, reflection and transmission), shaded at once; the
            # children of all lanes are compacted into the next depth's array. Contributions
            # are summed per pixel on the host in float64, in lane order (deterministic).
            n = dr.width(ray.o)
            acc = np.zeros((n, 3), dtype=np.float64)
            pix = dr.arange(mi.UInt32, n)
            cur_ray, weight, act, smp = mi.Ray3f(ray), mi.Color3f(1.0), mi.Bool(active), sampler
            for depth in range(self.max_depth + 1):
                contribution, children = self._shade(scene, smp, cur_ray, weight, depth, act)
                smp.schedule_state()
                dr.eval(contribution, children)
                m = dr.width(pix)
                np.add.at(acc, pix.numpy(), _host3(contribution, m))
                # Compact the children of every lane into the next depth's arrays (kept in Dr.Jit
                # memory: arrays made from host buffers would change the kernels' alignment and
                # defeat the kernel cache).
                parts = []
                for child_ray, child_w, child_mask in children:
                    if dr.any(child_mask):
                        idx = dr.compress(child_mask | dr.zeros(mi.Bool, m))
                        parts.append((idx, child_ray, child_w))
                if not parts:
                    break
                used = sum(dr.width(idx) for idx, _, _ in parts)
                # At least two lanes: a one-lane array is compiled as a scalar, a new kernel.
                total = max(used, 2)
                o, dd, w = dr.zeros(mi.Point3f, total), dr.zeros(mi.Vector3f, total), dr.zeros(mi.Color3f, total)
                nxt = dr.zeros(mi.UInt32, total)
                offset = 0
                for idx, child_ray, child_w in parts:
                    at = dr.arange(mi.UInt32, dr.width(idx)) + offset
                    dr.scatter(o, dr.gather(mi.Point3f, child_ray.o, idx), at)
                    dr.scatter(dd, dr.gather(mi.Vector3f, child_ray.d, idx), at)
                    dr.scatter(w, dr.gather(mi.Color3f, child_w, idx), at)
                    dr.scatter(nxt, dr.gather(mi.UInt32, pix, idx), at)
                    offset += dr.width(idx)
                dr.eval(o, dd, w, nxt)
                cur_ray, weight, pix = mi.Ray3f(o, dd), w, nxt
                act = dr.arange(mi.UInt32, total) < used
                # Mitsuba's independent sampler, forked and seeded for this depth's lanes
                # (opaque: a literal seed would make every pass compile its own kernels).
                smp = sampler.fork()
                smp.seed(dr.opaque(mi.UInt32, _seed32(getattr(self, "pass_seed", 0), depth + 1)), total)
            L = acc.astype(np.float32)
            return mi.Spectrum(mi.Float(L[:, 0]), mi.Float(L[:, 1]), mi.Float(L[:, 2])), mi.Bool(active), []

        def _sample_scalar(self, scene, sampler, ray, active):
            """The same tree, one pixel at a time (scalar_rgb): a stack of nodes."""
            total = mi.Color3f(0.0)
            stack = [(mi.Ray3f(ray), mi.Color3f(1.0), 0, bool(active))]
            while stack:
                node_ray, weight, depth, act = stack.pop()
                contribution, children = self._shade(scene, sampler, node_ray, weight, depth, act)
                total += contribution
                for child_ray, child_w, child_act in reversed(children):
                    if child_act:
                        stack.append((child_ray, child_w, depth + 1, True))
            return mi.Spectrum(total), mi.Bool(active), []

        def aov_names(self):
            return []

        def to_string(self):
            return f"RtdiffWhitted[max_depth={self.max_depth}]"

    mi.register_integrator("rtdiff_whitted", lambda props: RtdiffWhitted(props))


def load(mi, scene_dir: str):
    """Load an export. A plugin export: DIR/scene.xml without merging shapes (the integrator maps
    shape ids to materials). A native export: every scene of its recipe (rtdiff.json "recipe":
    each emitter file with each BSDF file, through scene.xml's $lights and $bsdfs), as
    {(lights, bsdfs): scene}."""
    cfg = config(scene_dir)
    path = os.path.join(scene_dir, "scene.xml")
    if cfg.get("oracle") != "native":
        return mi.load_file(path, optimize=False)
    recipe = cfg["recipe"]
    return {(l, b): mi.load_file(path, lights=l, bsdfs=b) for l in recipe["lights"] for b, _ in recipe["terms"]}


def config(scene_dir: str) -> dict:
    with open(os.path.join(scene_dir, "rtdiff.json")) as f:
        return json.load(f)


def render(mi, scene, cfg: dict, seed: int, passes: int | None = None) -> np.ndarray:
    """One image (H x W x 3 float32) of an export loaded by `load`.

    Native: Mitsuba's own render loop (`mi.render`) on each scene of the recipe, all with the
    same seed, summed with the recipe's weights in float64 (`passes` replaces the samples per
    pixel). Plugin: the mean of `passes` samples per pixel, pixel positions as rtdiff places them
    (centre for spp 1, n x n jittered grid for n*n, uniform otherwise), each with one lens sample
    when depth of field is on. `passes` defaults to spp * dof_samples."""
    if cfg.get("oracle") == "native":
        return render_native(mi, scene, cfg, seed, passes)
    import drjit as dr

    W, H = int(cfg["width"]), int(cfg["height"])
    spp, dof = int(cfg["spp"]), int(cfg["dof_samples"])
    passes = passes or spp * dof
    sensor = scene.sensors()[0]
    integrator = scene.integrator()
    sampler = mi.load_dict({"type": "independent"})
    k = round(math.sqrt(spp))
    square = k * k == spp and spp > 1
    scalar = mi.variant().startswith("scalar")
    acc = np.zeros((H, W, 3), dtype=np.float64)
    lens_on = cfg["plan"]["depth_of_field"]
    for p in range(passes):
        s = (p // dof) % spp  # camera sample index (each camera sample gets `dof` lens samples)
        stream = (seed * 1_000_003 + p) & 0x7FFFFFFF
        if hasattr(integrator, "set_pass_seed"):
            integrator.set_pass_seed(stream)
        if scalar:
            for y in range(H):
                for x in range(W):
                    sampler.seed(stream * W * H + y * W + x, 1)
                    L = _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on)
                    acc[y, x] += np.array([L[0], L[1], L[2]], dtype=np.float64)
            continue
        sampler.seed(dr.opaque(mi.UInt32, _seed32(stream, 0)), W * H)
        idx = dr.arange(mi.UInt32, W * H)
        x, y = mi.Float(idx % W), mi.Float(idx // W)
        L = _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on)
        dr.eval(L)
        acc += np.stack([np.array(L[0]), np.array(L[1]), np.array(L[2])], axis=-1).reshape(H, W, 3)
    return (acc / passes).astype(np.float32)


def render_native(mi, scenes: dict, cfg: dict, seed: int, spp: int | None = None) -> np.ndarray:
    """The recipe of a native export: sum over its emitter files and BSDF terms of
    weight * mi.render(scene, seed), every render with the same seed (the terms of one mirror
    bounce, 4 L(1/2) - L(1), cancel diffuse interreflection sample by sample)."""
    recipe = cfg["recipe"]
    weights = dict((b, w) for b, w in recipe["terms"])
    spp = spp or int(recipe["spp"])
    acc = np.zeros((int(cfg["height"]), int(cfg["width"]), 3), dtype=np.float64)
    # Hashed, as the plugin's seeds are: Mitsuba seeds each lane's PCG32 with only a 4-round TEA of
    # (seed, lane), so consecutive seeds are kept well apart.
    mixed = _seed32(seed, 0)
    for (_, b), scene in scenes.items():
        img = np.array(mi.render(scene, seed=mixed, spp=spp), dtype=np.float64)
        acc += weights[b] * img[:, :, :3]
    return acc.astype(np.float32)


def _camera_sample(mi, sensor, integrator, scene, sampler, x, y, W, H, spp, s, k, square, lens_on):
    """Radiance of camera sample `s` in pixel(s) (x, y): the centre for spp 1, stratum (s % k, s // k)
    of a k x k jittered grid for a square spp, uniform otherwise; one lens sample when lens_on."""
    if spp == 1:
        ox, oy = 0.5, 0.5
    elif square:
        j = sampler.next_2d()
        cx, cy = s % k, s // k
        if not mi.variant().startswith("scalar"):
            # Opaque: one JIT kernel serves every stratum (a literal would compile one per pass).
            import drjit as dr

            cx, cy = dr.opaque(mi.Float, cx), dr.opaque(mi.Float, cy)
        ox, oy = (cx + j.x) / k, (cy + j.y) / k
    else:
        j = sampler.next_2d()
        ox, oy = j.x, j.y
    lens = sampler.next_2d() if lens_on else mi.Point2f(0.5, 0.5)
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + ox) / W, (y + oy) / H), lens)
    L, _, _ = integrator.sample(scene, sampler, ray)
    return L


def write_exr(path: str, img: np.ndarray):
    """Byte-deterministic linear float32 RGB EXR (scanline, zip, written by OpenImageIO in one thread)."""
    import OpenImageIO as oiio

    oiio.attribute("threads", 1)
    h, w, _ = img.shape
    spec = oiio.ImageSpec(w, h, 3, oiio.FLOAT)
    spec.channelnames = ("R", "G", "B")
    spec.attribute("compression", "zip")
    spec.attribute("openexr:lineOrder", "increasingY")
    spec.attribute("DateTime", "")  # OpenEXR would stamp the time: no timestamp, byte-identical files
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        raise OSError(f"{path}: cannot write EXR: {oiio.geterror()}")
    out.write_image(np.ascontiguousarray(img, dtype=np.float32))
    out.close()


def read_exr(path: str) -> np.ndarray:
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(path)
    if buf.has_error:
        raise OSError(f"{path}: {buf.geterror()}")
    return buf.get_pixels(oiio.FLOAT)[:, :, :3]


def timed_render(mi, scene_dir: str, seed: int, passes: int | None = None):
    """Load the export in `scene_dir` and render it once; returns (image, seconds, config)."""
    cfg = config(scene_dir)
    scene = load(mi, scene_dir)
    t0 = time.perf_counter()
    img = render(mi, scene, cfg, seed, passes)
    return img, time.perf_counter() - t0, cfg
