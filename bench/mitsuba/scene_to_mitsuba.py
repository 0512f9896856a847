#!/usr/bin/env python3
"""Convert a baked photonflow scene.h5 into a Mitsuba 3 scene (XML + one OBJ per material).

Benchmark-only: Mitsuba is a comparator, never a dependency of photonflow. Converting from the
baked file keeps the geometry, textures and camera identical to what photonflow renders.

  scene_to_mitsuba.py scene.h5 OUTDIR [--spot exact|mitsuba] [--max-depth N]
      -> OUTDIR/scene.xml, OUTDIR/mat<K>.obj, OUTDIR/*.pfm (textures, the spot's falloff)

The XML takes three parameters (mitsuba.load_file(path, spp=..., seed=..., sampler=...)):
spp (default 16), seed (0) and sampler (independent, Mitsuba's default; multijitter or ldsampler
converge faster at light outlines and are what the references use, bench/mitsuba/README.md).

Mapping (docs/FORMATS.md, docs/SCENES.md, material/bsdf_shared.h; checked against photonflow's
own path tracer by bench/mitsuba/check_converter.py; the measured differences of the approximate
rows are in bench/mitsuba/README.md):
  type 0 diffuse  -> twosided(diffuse reflectance=color [x texture]): photonflow's Lambertian
                     reflects on the side the ray arrives from.                            exact
  type 1 mirror   -> twosided(conductor material="none" specular_reflectance=color).      exact
  type 2 glass    -> dielectric int_ior=ior ext_ior=1 specular_transmittance=color (exact Fresnel
                     both; the tint on transmission only, as specular_bounce).              exact
  type 3 emitter  -> area emitter radiance=emission on a twosided(diffuse(color [x texture]))
                     surface. photonflow emits one-sided along the geometric normal
                     cross(v1-v0, v2-v0); Mitsuba's area emitter emits on the side of the face
                     normal, the same cross product of the vertex order (no flip).          exact
  type 4 PF_MAT_PBR (glTF metallic-roughness; α = max(roughness², 10⁻³), GGX both):
    metallic 1, base colour 1, no metallic-roughness texture
                  -> twosided(roughconductor material="none" alpha=α): glTF's Schlick F with
                     F0 = 1 is 1 at every angle, as Mitsuba's "none" conductor.     exact model
    metallic 1, another base colour, no metallic-roughness texture
                  -> twosided(principled metallic=1 base_color roughness): Mitsuba's principled
                     metal is GGX with Schlick F0 = base colour, glTF's formula. (roughconductor
                     material="none" specular_reflectance=base would lose Schlick's rise to 1 at
                     grazing angles: a cosine-weighted albedo of F0 instead of F0 + (1 − F0)/21,
                     −8.6 % at gold's blue F0 0.336; a conductor with k = 0 and the eta of F0 has
                     a Brewster dip, −5 % at F0 0.766.)                              approximate
    metallic 0, transmission 0, no metallic-roughness texture (glTF's dielectric, fresnel_mix:
    (1 − F_Schlick(v·h)) base/π + F_Schlick(v·h) D V)
                  -> twosided(blendbsdf weight 0.5 of diffuse reflectance=2·W·base [texture] and
                     roughconductor ggx alpha=α eta=ior k=0 specular_reflectance=2): the coat
                     with the exact dielectric Fresnel of ior (a conductor with k = 0), the base
                     weighted by W = the mean of 1 − F_Schlick(v·h) over cosine-weighted view and
                     light directions (diffuse_weight; 0.9565 at ior 1.5, the same at every
                     roughness) instead of its value per direction pair. Tried and not used:
                     roughplastic (nonlinear=false), albedo 0.47 for a white base at α 0.64 where
                     glTF's is 0.98 (the showcase 11 % dark), and principled, whose Disney
                     diffuse adds a retro-reflection (albedo 1.04–1.07).            approximate
    transmission 1, metallic 0, no metallic-roughness texture
                  -> roughdielectric distribution=ggx alpha=α int_ior=ior ext_ior=1
                     specular_transmittance=base (KHR_materials_transmission's BTDF tinted by the
                     base colour at each crossing, as Mitsuba's specular_transmittance; the
                     reflection untinted in both). Exact Fresnel in Mitsuba, Schlick (at the
                     cosine on the lower-index side) in photonflow.             near-exact model
    a metallic-roughness texture, or 0 < metallic < 1, no transmission
                  -> twosided(blendbsdf weight=metallic [texture] of the dielectric blend above
                     and the metal above), the roughness as textures where the material has a
                     metallic-roughness texture (metallic = factor × B, roughness = factor × G,
                     α = (factor × G)² per texel, the texel filter and wrap of the scene; with a
                     bilinear filter α is interpolated where photonflow interpolates G).
                                                                                     approximate
    0 < transmission < 1, or transmission with a metallic-roughness texture
                  -> principled base_color metallic roughness eta=ior spec_trans=transmission
                     (not in the bundled scenes; not measured).                     approximate
    Every Mitsuba microfacet plugin uses the separable Smith G1(o)·G1(i); photonflow the
    height-correlated one (slightly more reflection at grazing angles, both single-scattering).
  textures -> bitmap textures read from PFM files (32-bit float, linear): scene.h5 stores its
              texels linear (base-colour images sRGB-decoded at bake time, docs/FORMATS.md), so the
              PFM holds the material's factor × texel as photonflow multiplies them, and Mitsuba
              reads the same linear values (raw=true, no conversion of float data). Filter
              bilinear/nearest and wrap repeat/clamp/mirror as the scene's header (one wrap mode
              for u and v: a texture that wraps them differently is refused); Mitsuba and
              photonflow both put texel centres at (i + ½)/width. UVs are written as stored (glTF:
              (0, 0) the image's top-left, v down) with flip_tex_coords=false, which is Mitsuba's
              own uv convention for bitmaps (row 0 at v = 0).
  alpha cut-outs (/materials/alpha_*) -> mask(opacity=...) around the BSDF, the opacity a 0/1
              map (nearest filter) of "alpha = factor × texel alpha ≥ cutoff" evaluated at
              MASK_SUPERSAMPLE² points per texel with photonflow's bilinear filter, so the outline
              is photonflow's to 1/MASK_SUPERSAMPLE texel. A scene with a mask is rendered
              with `volpath` (no media here: the same estimator as `path`), whose shadow rays
              pass null surfaces, a mask's holes; `path`'s shadow rays stop at them.
  point lights (type 1) -> point emitter, intensity = the stored intensity (W/sr).         exact
  spot lights (type 2)  -> spot emitter aimed along `direction`. KHR_lights_punctual's falloff
              is smooth in cos θ, clamp((cos θ − cos_outer)/(cos_inner − cos_outer), 0, 1)²;
              Mitsuba's is linear in the angle θ from beam_width to cutoff_angle. --spot exact
              (the default): cutoff_angle = beam_width = the outer angle (Mitsuba's own falloff a
              step) and the glTF falloff as the spot's projected `texture` (SPOT_RES² texels over
              tan θ / tan θ_outer, bilinear: the falloff to < 10⁻³). --spot mitsuba: Mitsuba's own
              falloff with cutoff_angle = outer, beam_width = inner (to measure the difference).
  directional lights (type 3) -> directional emitter, irradiance = the stored irradiance (W/m²),
              direction as stored (photonflow's emitting disc lies outside the scene's bounds,
              so inside them the light is the same).                                       exact
  environment (type 4 light, /environment, format 6) -> envmap emitter, filename env.pfm (32-bit
              float PFM, read linear), scale = strength, to_world = rotate(y, rotation_deg):
              photonflow looks d up at d_l = R_y(−ρ)·d with R_y right-handed (+z towards +x for
              90°), Mitsuba at to_world⁻¹·d with the same right-handed rotate, so to_world =
              R_y(+ρ). Same u = atan2(d_l.x, −d_l.z)/2π, v = acos(d_l.y)/π. Mitsuba's envmap is
              bilinear with column j at u = (j + ½)/W but row i at v = i/(H − 1) (rows at the
              poles), photonflow texel-constant with row i over [i/H, (i + 1)/H): env.pfm is the map
              resampled to ENV_UPSAMPLE_COLS·W columns (each texel repeated) and
              ENV_UPSAMPLE_ROWS·H + 1 rows (the row at v = r/(ENV_UPSAMPLE_ROWS·H) is the texel it
              lies in, the mean of the two where it lies on a texel edge), so Mitsuba's bilinear
              ramp is 1/ENV_UPSAMPLE_COLS of a texel wide across columns, 2/ENV_UPSAMPLE_ROWS across
              rows, centred on photonflow's texel edges (bench/mitsuba/check_env.py compares the
              two lookups on a grid of directions). Rows get more: a horizon is a row edge seen
              directly.                                                          near-exact
  flat meshes (n0=n1=n2=geometric normal) -> face_normals=true; otherwise the file's vertex normals.
  camera -> perspective (thinlens with aperture_radius/focus_distance when aperture > 0),
            fov_axis="y", lookat eye/look_at/up, box rfilter (a pixel = the mean radiance over it,
            as photonflow's pixel), hdrfilm rgb.
  integrator -> path (volpath with a mask), max_depth -1 (unlimited; photonflow's paths are cut at
                16 bounces (render) or 64 (pathtrace), which loses < 0.1 % here).
Refused (exit 2, one line): a masked emitter, a material type outside 0..4, a texture whose
wrap modes differ in u and v.
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

MASK_SUPERSAMPLE = 8
ENV_UPSAMPLE_COLS = 4   # 512 x 256 map: ramp 0.18 deg wide across columns
ENV_UPSAMPLE_ROWS = 32  # and 0.044 deg across rows (0.6 px of a 38-deg, 512-px camera)
SPOT_RES = 512
ALPHA_MIN = 1e-3  # PF_BSDF_ALPHA_MIN


def fmt3(v):
    return ", ".join("%.9g" % x for x in v)


def refuse(path, what):
    sys.stderr.write("scene_to_mitsuba: %s: %s\n" % (path, what))
    raise SystemExit(2)


def write_pfm(path, img):
    """img: H x W x 3 or H x W (row 0 the top); PFM stores rows bottom-up, little-endian."""
    img = np.asarray(img, dtype="<f4")
    kind = "PF" if img.ndim == 3 else "Pf"
    h, w = img.shape[:2]
    with open(path, "wb") as o:
        o.write(("%s\n%d %d\n-1.0\n" % (kind, w, h)).encode())
        o.write(np.ascontiguousarray(img[::-1]).tobytes())


def texture_image(tex, texels):
    """The header's texels as H x W x 4 (row 0 the image's top row)."""
    w, h, off = int(tex["width"]), int(tex["height"]), int(tex["offset"])
    return texels[off:off + w * h].reshape(h, w, 4).astype(np.float64)


def wrap_index(i, n, mode):  # texture_shared.h pf_tex_wrap_index
    if mode == 1:
        return np.clip(i, 0, n - 1)
    if mode == 2:
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    return np.mod(i, n)


def sample_bilinear(img, tex, u, v):
    """photonflow's pf_tex_sample (texture_shared.h) at arrays u, v in [0, 1): rgba."""
    h, w = img.shape[:2]
    x, y = u * w, v * h
    if int(tex["filter"]) == 1:
        return img[wrap_index(np.floor(y).astype(int), h, int(tex["wrap_t"])),
                   wrap_index(np.floor(x).astype(int), w, int(tex["wrap_s"]))]
    xs, ys = x - 0.5, y - 0.5
    x0, y0 = np.floor(xs), np.floor(ys)
    fx, fy = (xs - x0)[..., None], (ys - y0)[..., None]
    x0, y0 = x0.astype(int), y0.astype(int)
    X0, X1 = wrap_index(x0, w, int(tex["wrap_s"])), wrap_index(x0 + 1, w, int(tex["wrap_s"]))
    Y0, Y1 = wrap_index(y0, h, int(tex["wrap_t"])), wrap_index(y0 + 1, h, int(tex["wrap_t"]))
    top = img[Y0, X0] * (1 - fx) + img[Y0, X1] * fx
    bot = img[Y1, X0] * (1 - fx) + img[Y1, X1] * fx
    return top * (1 - fy) + bot * fy


def diffuse_weight(ior, n=256):
    """glTF's fresnel_mix diffuse weight averaged: (1/π) ∫∫ (1 − F_Schlick(v·h)) cos θ_l cos θ_v
    dω_l dω_v / π over both hemispheres (midpoint rule in cos θ and φ; independent of roughness)."""
    f0 = ((ior - 1) / (ior + 1)) ** 2
    mu = (np.arange(n) + 0.5) / n
    phi = (np.arange(n) + 0.5) / n * np.pi  # symmetric in φ
    cv, cl, ph = np.meshgrid(mu, mu, phi, indexing="ij")
    sv, sl = np.sqrt(1 - cv * cv), np.sqrt(1 - cl * cl)
    vh = np.sqrt(np.maximum(0.5 * (1 + cv * cl + sv * sl * np.cos(ph)), 0))  # cos of half the angle
    F = f0 + (1 - f0) * (1 - vh) ** 5
    # ∫ cos_l dω_l / π = 1 and ∫ cos_v dω_v / π = 1: the means over the μ² (d(μ²)) measure
    return float(np.mean((1 - F) * (2 * cv) * (2 * cl)))


def env_resample(tex, kc, k):
    """photonflow's texel-constant H x 2H map as Mitsuba envmap data (kc·2H columns, k·H + 1 rows):
    column j (Mitsuba's u = (j + ½)/(kc·W)) = texel column ⌊j/kc⌋; row r (Mitsuba's v = r/(k·H)) =
    texel row r/k, or the mean of rows r/k − 1 and r/k where r is a multiple of k inside the map."""
    H = tex.shape[0]
    t = np.repeat(np.asarray(tex, np.float32), kc, axis=1)
    r = np.arange(k * H + 1)
    lo = np.clip((r - 1) // k, 0, H - 1)  # the row just above v, or v's own
    hi = np.clip(r // k, 0, H - 1)
    edge = (r % k == 0)
    lo = np.where(edge, lo, hi)
    return 0.5 * (t[lo] + t[hi])


def spot_falloff(c, cos_inner, cos_outer):  # light_shared.h pf_spot_falloff
    width = max(cos_inner - cos_outer, 0.001)
    t = np.clip((c - cos_outer) / width, 0.0, 1.0)
    return t * t


class Converter:
    def __init__(self, h5path, outdir, spot="exact"):
        self.h5path, self.outdir, self.spot = h5path, outdir, spot
        with h5py.File(h5path, "r") as f:
            if f.attrs.get("format", b"") not in (b"photonflow.scene", "photonflow.scene"):
                refuse(h5path, "not a photonflow scene (format attribute); bake it with scene-bake first")
            self.tris = f["geometry/triangles"][:]
            self.mats = f["materials/materials"][:]
            self.cam = f["camera"][0]
            self.lights = f["lights/lights"][:]
            K = len(self.mats)
            none = np.full(K, -1)
            self.base_tex = f["materials/texture"][:] if "materials/texture" in f else none
            self.mr_tex = (f["materials/metallic_roughness_texture"][:]
                           if "materials/metallic_roughness_texture" in f else none)
            if "materials/alpha_cutoff" in f:
                self.alpha_cutoff = f["materials/alpha_cutoff"][:]
                self.alpha_factor = f["materials/alpha_factor"][:]
                self.alpha_tex = f["materials/alpha_texture"][:]
            else:
                self.alpha_cutoff, self.alpha_factor, self.alpha_tex = np.full(K, -1.0), np.ones(K), none
            self.textures = f["textures/textures"][:] if "textures/textures" in f else None
            self.texels = f["textures/texels"][:].reshape(-1, 4) if "textures/texels" in f else None
            self.uvs = f["geometry/uvs"][:].reshape(-1, 6) if "geometry/uvs" in f else None
            self.env = None
            if "environment" in f:
                e = f["environment"]
                self.env = (e["texels"][:], float(e.attrs["strength"]), float(e.attrs["rotation_deg"]))
        self.has_mask = False

    # ---- textures ------------------------------------------------------------------------
    def bitmap(self, name, img, tex, channels):
        """A bitmap texture element of img (H x W x channels) with the header's filter and wrap."""
        fn = name + ".pfm"
        write_pfm(os.path.join(self.outdir, fn), img if channels == 3 else img[..., 0])
        wrap = {0: "repeat", 1: "clamp", 2: "mirror"}
        if int(tex["wrap_s"]) != int(tex["wrap_t"]):  # Mitsuba's bitmap has one wrap_mode for u and v
            refuse(self.h5path, "texture of %s wraps u and v differently (Mitsuba's bitmap cannot)" % name)
        return ('<texture type="bitmap" name="%%s"><string name="filename" value="%s"/>'
                '<boolean name="raw" value="true"/><string name="filter_type" value="%s"/>'
                '<string name="wrap_mode" value="%s"/></texture>'
                % (fn, "nearest" if int(tex["filter"]) == 1 else "bilinear", wrap[int(tex["wrap_s"])]))

    def colour(self, k, param, factor):
        """<rgb> of factor, or the bitmap factor x base-colour texel of material k."""
        t = int(self.base_tex[k])
        if t < 0:
            return '<rgb name="%s" value="%s"/>' % (param, fmt3(factor))
        tex = self.textures[t]
        img = texture_image(tex, self.texels)[..., :3] * np.asarray(factor, np.float64)[None, None, :]
        return self.bitmap("mat%d_base" % k, img, tex, 3) % param

    def mr_textures(self, k, m):
        """(metallic, roughness) elements of material k: floats, or bitmaps of factor x B / G."""
        t = int(self.mr_tex[k])
        if t < 0:
            return ('<float name="metallic" value="%.9g"/>' % m["metallic"],
                    '<float name="roughness" value="%.9g"/>' % max(float(m["roughness"]), math.sqrt(ALPHA_MIN)))
        tex = self.textures[t]
        img = texture_image(tex, self.texels)
        met = img[..., 2:3] * float(m["metallic"])
        rough = img[..., 1:2] * float(m["roughness"])
        return (self.bitmap("mat%d_metallic" % k, met, tex, 1) % "metallic",
                self.bitmap("mat%d_roughness" % k, rough, tex, 1) % "roughness")

    def mask(self, k, bsdf):
        cutoff = float(self.alpha_cutoff[k])
        if cutoff < 0:
            return bsdf
        self.has_mask = True
        t = int(self.alpha_tex[k])
        factor = float(self.alpha_factor[k])
        if t < 0:  # a constant alpha: all or nothing
            keep = factor >= cutoff
            return bsdf if keep else '<bsdf type="null"/>'
        tex = self.textures[t]
        img = texture_image(tex, self.texels)
        S = MASK_SUPERSAMPLE
        h, w = img.shape[:2]
        v, u = np.mgrid[0:h * S, 0:w * S].astype(np.float64)
        a = sample_bilinear(img, tex, (u + 0.5) / (w * S), (v + 0.5) / (h * S))[..., 3]
        # pf_alpha_cut_away: cut when factor * alpha < cutoff (single-precision product)
        opaque = (np.float32(factor) * a.astype(np.float32) >= np.float32(cutoff)).astype(np.float64)
        fake = {"filter": 1, "wrap_s": tex["wrap_s"], "wrap_t": tex["wrap_t"]}
        return ('<bsdf type="mask">%s%s</bsdf>'
                % (self.bitmap("mat%d_opacity" % k, opaque[..., None], fake, 1) % "opacity", bsdf))

    # ---- materials -----------------------------------------------------------------------
    def bsdf(self, k):
        m = self.mats[k]
        t, c = int(m["type"]), m["color"]
        two = '<bsdf type="twosided">%s</bsdf>'
        if t in (0, 3):
            b = two % ('<bsdf type="diffuse">%s</bsdf>' % self.colour(k, "reflectance", c))
            if t == 3:
                if float(self.alpha_cutoff[k]) >= 0:
                    refuse(self.h5path, "material %d is a masked emitter (not converted)" % k)
                b += '<emitter type="area"><rgb name="radiance" value="%s"/></emitter>' % fmt3(m["emission"])
                return b
        elif t == 1:
            b = two % ('<bsdf type="conductor"><string name="material" value="none"/>'
                       '<rgb name="specular_reflectance" value="%s"/></bsdf>' % fmt3(c))
        elif t == 2:
            b = ('<bsdf type="dielectric"><float name="int_ior" value="%.9g"/><float name="ext_ior" value="1"/>'
                 '<rgb name="specular_transmittance" value="%s"/></bsdf>' % (m["ior"], fmt3(c)))
        elif t == 4:
            b = self.pbr(k, m)
        else:
            refuse(self.h5path, "material %d has unknown type %d" % (k, t))
        return self.mask(k, b)

    def pbr(self, k, m):
        c = np.asarray(m["color"], np.float64)
        metallic, rough, trans, ior = (float(m[x]) for x in ("metallic", "roughness", "transmission", "ior"))
        alpha = max(rough * rough, ALPHA_MIN)
        mr = int(self.mr_tex[k]) >= 0
        white = bool(np.all(c == 1.0)) and int(self.base_tex[k]) < 0
        two = '<bsdf type="twosided">%s</bsdf>'
        if trans > 0 and metallic < 1:
            if not mr and metallic == 0.0 and trans == 1.0:
                self.kinds[k] = "roughdielectric"
                return ('<bsdf type="roughdielectric"><string name="distribution" value="ggx"/>'
                        '<float name="alpha" value="%.9g"/><float name="int_ior" value="%.9g"/>'
                        '<float name="ext_ior" value="1"/>%s</bsdf>'
                        % (alpha, ior, self.colour(k, "specular_transmittance", c)))
            self.kinds[k] = "principled (transmission)"
            met, rgh = self.mr_textures(k, m)
            return ('<bsdf type="principled">%s%s%s<float name="eta" value="%.9g"/>'
                    '<float name="spec_trans" value="%.9g"/></bsdf>'
                    % (self.colour(k, "base_color", c), met, rgh, ior, trans))
        met, rgh = self.mr_textures(k, m)
        if mr:
            t = self.textures[int(self.mr_tex[k])]
            img = texture_image(t, self.texels)
            r2 = np.maximum((img[..., 1:2] * rough) ** 2, ALPHA_MIN)
            alpha_el = self.bitmap("mat%d_alpha" % k, r2, t, 1) % "alpha"
        else:
            alpha_el = '<float name="alpha" value="%.9g"/>' % alpha
        # metal: glTF's Schlick F with F0 = base colour
        if white and not mr:
            metal = ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/>'
                     '<string name="material" value="none"/>%s</bsdf>' % alpha_el)
        else:
            metal = ('<bsdf type="principled">%s<float name="metallic" value="1"/>%s</bsdf>'
                     % (self.colour(k, "base_color", c), rgh))
        # dielectric: fresnel_mix = (1 − F(v·h)) base/π + F(v·h) D V, as a half/half blend of a
        # diffuse base of albedo W·base (W the cosine-weighted mean of (1 − F) over view and light
        # directions, which depends on the ior only) and a GGX coat with the exact Fresnel of ior
        # (a conductor of eta = ior, k = 0), each scaled by 2 (floats: Mitsuba range-checks only rgb).
        w = diffuse_weight(ior)
        if int(self.base_tex[k]) >= 0:
            base = self.colour(k, "reflectance", c * 2 * w)
        else:
            base = ('<rgb name="reflectance" value="%s"/>' % fmt3(c * 2 * w) if np.all(c * 2 * w <= 1)
                    else self.const_bitmap(k, c * 2 * w))
        dielectric = ('<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse">%s</bsdf>'
                      '<bsdf type="roughconductor"><string name="distribution" value="ggx"/>%s'
                      '<float name="eta" value="%.9g"/><float name="k" value="0"/>'
                      '<float name="specular_reflectance" value="2"/></bsdf></bsdf>' % (base, alpha_el, ior))
        if not mr and metallic == 1.0:
            self.kinds[k] = "roughconductor none" if white else "principled metal"
            return two % metal
        if not mr and metallic == 0.0:
            self.kinds[k] = "diffuse+coat blend"
            return two % dielectric
        self.kinds[k] = "blend(metallic; diffuse+coat, principled metal)"
        return two % ('<bsdf type="blendbsdf">%s%s%s</bsdf>' % (met.replace('name="metallic"', 'name="weight"'),
                                                                dielectric, metal))

    def const_bitmap(self, k, rgb):
        """A 1 x 1 bitmap of rgb (values above 1, which an <rgb> reflectance refuses)."""
        img = np.broadcast_to(np.asarray(rgb, np.float64), (1, 1, 3))
        return self.bitmap("mat%d_base" % k, img, {"filter": 1, "wrap_s": 0, "wrap_t": 0}, 3) % "reflectance"

    # ---- the scene -----------------------------------------------------------------------
    def convert(self, max_depth=-1):
        os.makedirs(self.outdir, exist_ok=True)
        self.kinds = {}
        tris = self.tris
        shapes = []
        for k in range(len(self.mats)):
            idx = np.nonzero(tris["material"] == k)[0]
            if len(idx) == 0:
                continue
            sel = tris[idx]
            v = np.stack([sel["v0"], sel["v1"], sel["v2"]], axis=1).astype(np.float64)  # T,3,3
            n = np.stack([sel["n0"], sel["n1"], sel["n2"]], axis=1).astype(np.float64)
            g = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
            g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
            flat = bool(np.all(np.abs(n - g[:, None, :]) < 1e-4))
            textured = (int(self.base_tex[k]) >= 0 or int(self.mr_tex[k]) >= 0 or
                        (float(self.alpha_cutoff[k]) >= 0 and int(self.alpha_tex[k]) >= 0))
            name = "mat%d.obj" % k
            T = len(sel)
            with open(os.path.join(self.outdir, name), "w") as o:
                o.write("# photonflow material %d (type %d), %d triangles\n" % (k, self.mats[k]["type"], T))
                o.write("".join("v %.9g %.9g %.9g\n" % tuple(p) for p in v.reshape(-1, 3)))
                if textured:
                    o.write("".join("vt %.9g %.9g\n" % tuple(p) for p in self.uvs[idx].reshape(-1, 2)))
                if not flat:
                    o.write("".join("vn %.9g %.9g %.9g\n" % tuple(p) for p in n.reshape(-1, 3)))
                ids = np.arange(1, 3 * T + 1).reshape(T, 3)
                if textured and not flat:
                    fl = ("f %d/%d/%d %d/%d/%d %d/%d/%d\n" % tuple(np.repeat(r, 3)) for r in ids)
                elif textured:
                    fl = ("f %d/%d %d/%d %d/%d\n" % tuple(np.repeat(r, 2)) for r in ids)
                elif not flat:
                    fl = ("f %d//%d %d//%d %d//%d\n" % tuple(np.repeat(r, 2)) for r in ids)
                else:
                    fl = ("f %d %d %d\n" % tuple(r) for r in ids)
                o.write("".join(fl))
            bsdf = self.bsdf(k)
            shapes.append('  <shape type="obj" id="mat%d"><string name="filename" value="%s"/>'
                          '<boolean name="face_normals" value="%s"/><boolean name="flip_tex_coords" value="false"/>'
                          '%s</shape>' % (k, name, "true" if flat else "false", bsdf))
        for i, L in enumerate(self.lights):
            t = int(L["type"])
            if t == 1:
                shapes.append('  <emitter type="point"><point name="position" value="%s"/>'
                              '<rgb name="intensity" value="%s"/></emitter>' % (fmt3(L["position"]), fmt3(L["radiance"])))
            elif t == 2:
                shapes.append("  " + self.spot_light(i, L))
            elif t == 3:
                shapes.append('  <emitter type="directional"><vector name="direction" value="%s"/>'
                              '<rgb name="irradiance" value="%s"/></emitter>' % (fmt3(L["direction"]), fmt3(L["radiance"])))
            elif t == 4:
                shapes.append("  " + self.environment())
        cam = self.cam
        lens = ""
        sensor = "perspective"
        if cam["aperture"] > 0:
            sensor = "thinlens"
            lens = ('<float name="aperture_radius" value="%.9g"/><float name="focus_distance" value="%.9g"/>'
                    % (cam["aperture"], cam["focus_distance"]))
        integrator = "volpath" if self.has_mask else "path"
        xml = """<scene version="3.0.0">
  <default name="spp" value="16"/>
  <default name="seed" value="0"/>
  <default name="sampler" value="independent"/>
  <integrator type="%s"><integer name="max_depth" value="%d"/></integrator>
  <sensor type="%s">
    <string name="fov_axis" value="y"/>
    <float name="fov" value="%.9g"/>%s
    <transform name="to_world"><lookat origin="%s" target="%s" up="%s"/></transform>
    <sampler type="$sampler"><integer name="sample_count" value="$spp"/><integer name="seed" value="$seed"/></sampler>
    <film type="hdrfilm"><integer name="width" value="%d"/><integer name="height" value="%d"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/></film>
  </sensor>
%s
</scene>
""" % (integrator, max_depth, sensor, cam["fov_y_deg"], lens, fmt3(cam["eye"]), fmt3(cam["look_at"]),
           fmt3(cam["up"]), cam["width"], cam["height"], "\n".join(shapes))
        with open(os.path.join(self.outdir, "scene.xml"), "w") as o:
            o.write("<!-- scene_to_mitsuba.py %s: materials %s -->\n"
                    % (os.path.basename(self.h5path), ", ".join("%d %s" % kv for kv in sorted(self.kinds.items()))))
            o.write(xml)
        return os.path.join(self.outdir, "scene.xml")

    def environment(self):
        if self.env is None:
            refuse(self.h5path, "an environment light without /environment")
        tex, strength, rot = self.env
        write_pfm(os.path.join(self.outdir, "env.pfm"), env_resample(tex, ENV_UPSAMPLE_COLS, ENV_UPSAMPLE_ROWS))
        return ('<emitter type="envmap"><string name="filename" value="env.pfm"/>'
                '<float name="scale" value="%.9g"/><transform name="to_world"><rotate y="1" angle="%.9g"/>'
                '</transform></emitter>' % (strength, rot))

    def spot_light(self, i, L):
        ci, co = float(L["cos_inner"]), float(L["cos_outer"])
        th_i, th_o = math.degrees(math.acos(min(ci, 1.0))), math.degrees(math.acos(co))
        p = np.asarray(L["position"], np.float64)
        d = np.asarray(L["direction"], np.float64)
        up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        head = ('<emitter type="spot"><transform name="to_world"><lookat origin="%s" target="%s" up="%s"/></transform>'
                '<rgb name="intensity" value="%s"/>' % (fmt3(p), fmt3(p + d), fmt3(up), fmt3(L["radiance"])))
        if self.spot == "mitsuba":
            return head + ('<float name="cutoff_angle" value="%.9g"/><float name="beam_width" value="%.9g"/></emitter>'
                           % (th_o, th_i))
        # Mitsuba's texture lookup: uv = ½ + ½ (x/z, y/z) / tan(cutoff_angle) in the light's frame.
        R = SPOT_RES
        g = (np.arange(R) + 0.5) / R * 2 - 1  # (x/z) / tan(cutoff) at texel centres
        X, Y = np.meshgrid(g, g)
        t2 = (X * X + Y * Y) * math.tan(math.radians(th_o)) ** 2  # tan² θ
        img = spot_falloff(1 / np.sqrt(1 + t2), ci, co)
        tex = {"filter": 0, "wrap_s": 1, "wrap_t": 1}
        return head + ('<float name="cutoff_angle" value="%.9g"/><float name="beam_width" value="%.9g"/>%s</emitter>'
                       % (th_o, th_o, self.bitmap("spot%d_falloff" % i, img[..., None], tex, 1) % "texture"))


def convert(h5path, outdir, max_depth=-1, spot="exact"):
    return Converter(h5path, outdir, spot).convert(max_depth)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="baked scene.h5")
    ap.add_argument("outdir")
    ap.add_argument("--max-depth", type=int, default=-1, help="Mitsuba path max_depth (-1 = unlimited)")
    ap.add_argument("--spot", choices=["exact", "mitsuba"], default="exact",
                    help="spot falloff: glTF's as a projected texture (exact), or Mitsuba's own (mitsuba)")
    a = ap.parse_args()
    print(convert(a.scene, a.outdir, a.max_depth, a.spot))
