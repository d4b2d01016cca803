//! BSDFs and textures: Mitsuba plugins → `cmlt::scene::Material`.
//!
//! Parsed materials are memoised per XML element, so a BSDF referenced by
//! many shapes is one material. A material is added to the scene only when
//! a shape uses it (the renderer inspects the scene's materials to decide
//! which effects to simulate, so an unused glass BSDF must not appear), but
//! unused top-level BSDFs are still parsed, because Mitsuba instantiates
//! them and rejects invalid ones.

use std::path::PathBuf;

use cmlt::math::Rgb;
use cmlt::scene::{
    BitmapId, ConductorFresnel, Distribution, MAX_ROUGHNESS, Material, MaterialId, MaterialKind,
    PrincipledParams, RoughCoating, Texture, roughness_ok,
};
use glam::Affine2;
use roxmltree::Node;

use super::conductor_presets::CONDUCTOR_PRESETS;
use super::error::LoadError;
use super::loader::Loader;
use super::transform;
use super::xml::{Entry, Item, Props, Value, key};

/// Deepest nesting of BSDFs (`twosided` around `twosided` …) we follow.
const MAX_BSDF_DEPTH: usize = 8;

/// Mitsuba's named indices of refraction (`include/mitsuba/render/ior.h`,
/// values from Hecht, *Optics*, at ~589 nm).
const NAMED_IORS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Decoded texture data (a bitmap, a voxel grid) waiting to be added to
/// the scene: only a material that is used adds it, once.
pub(crate) struct Pending<T, Id> {
    item: Option<T>,
    id: Option<Id>,
}

impl<T, Id: Copy> Pending<T, Id> {
    /// Data not yet in the scene.
    pub fn new(item: T) -> Self {
        Pending {
            item: Some(item),
            id: None,
        }
    }

    /// The scene's id of the data, handing it to `add` the first time.
    pub fn add_once(&mut self, add: impl FnOnce(T) -> Id) -> Id {
        if let Some(id) = self.id {
            return id;
        }
        let id = add(self.item.take().expect("pending data is added once"));
        self.id = Some(id);
        id
    }
}

fn rgb(c: [f64; 3]) -> Rgb {
    Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

impl<'a> Loader<'a> {
    /// The material of a `<bsdf>` element, added to the scene on first use.
    pub(crate) fn use_bsdf(&mut self, node: Node<'a, 'a>) -> Result<MaterialId, LoadError> {
        if let Some(&id) = self.used_materials.get(&key(node)) {
            return Ok(id);
        }
        let m = self.bsdf(node, 0)?;
        let id = self.add_material(m, Some(node));
        self.used_materials.insert(key(node), id);
        Ok(id)
    }

    /// Mitsuba's default BSDF of a shape without one: one-sided diffuse 0.5,
    /// or black when the shape is an emitter (Mitsuba's Shape constructor).
    pub(crate) fn default_material(&mut self, emitter: bool) -> MaterialId {
        let slot = emitter as usize;
        if let Some(id) = self.default_materials[slot] {
            return id;
        }
        let albedo = if emitter { 0.0 } else { 0.5 };
        let m = Material {
            kind: MaterialKind::Diffuse {
                reflectance: Texture::Constant(Rgb::splat(albedo)),
            },
            two_sided: false,
            detail: Default::default(),
        };
        let id = self.add_material(m, None);
        self.default_materials[slot] = Some(id);
        id
    }

    /// Adds a parsed material, moving the bitmaps and grids it uses into
    /// the scene.
    fn add_material(&mut self, mut m: Material, origin: Option<Node<'a, 'a>>) -> MaterialId {
        let mut fix = |t: &mut Texture| match t {
            Texture::Grid(id) => {
                *id = self.grids[id.0 as usize].add_once(|g| self.builder.add_grid(g));
            }
            Texture::Bitmap { id, .. } => {
                *id = self.bitmaps[id.0 as usize].add_once(|b| self.builder.add_bitmap(b));
            }
            Texture::Constant(_) | Texture::Checkerboard { .. } => {}
        };
        for t in [
            &mut m.detail.normal_map,
            &mut m.detail.bump_map,
            &mut m.detail.opacity,
        ]
        .into_iter()
        .flatten()
        {
            fix(t);
        }
        match &mut m.kind {
            MaterialKind::Diffuse { reflectance }
            | MaterialKind::RoughDiffuse { reflectance, .. } => fix(reflectance),
            MaterialKind::Conductor {
                specular_reflectance,
                ..
            }
            | MaterialKind::RoughConductor {
                specular_reflectance,
                ..
            } => fix(specular_reflectance),
            MaterialKind::Dielectric { .. } => {}
            MaterialKind::TintedDielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            }
            | MaterialKind::ThinDielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            }
            | MaterialKind::RoughDielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                fix(specular_reflectance);
                fix(specular_transmittance);
            }
            MaterialKind::Plastic {
                diffuse_reflectance,
                specular_reflectance,
                ..
            }
            | MaterialKind::RoughPlastic {
                diffuse_reflectance,
                specular_reflectance,
                ..
            } => {
                fix(diffuse_reflectance);
                fix(specular_reflectance);
            }
            MaterialKind::Principled(p) => p.textures_mut().into_iter().for_each(fix),
            MaterialKind::Null => {}
        }
        self.material_origin.push(origin);
        self.builder.add_material(m)
    }

    /// Parses a `<bsdf>` element (textures refer to pending bitmaps).
    pub(crate) fn bsdf(&mut self, node: Node<'a, 'a>, depth: usize) -> Result<Material, LoadError> {
        if let Some(m) = self.bsdf_memo.get(&key(node)) {
            return Ok(*m);
        }
        if depth > MAX_BSDF_DEPTH {
            return Err(self.xml.err(
                node,
                format!("BSDFs nested too deeply (more than {MAX_BSDF_DEPTH} levels)"),
            ));
        }
        let props = Props::read(&self.xml, node)?;
        let mut ignored: &[&str] = &[];
        let m = match props.plugin.as_str() {
            "twosided" => {
                let x = &self.xml;
                let nested = props.objects("bsdf");
                let inner = match nested.as_slice() {
                    [one] => {
                        let Item::Object(n) = one.item else {
                            unreachable!("objects() returns objects")
                        };
                        n
                    }
                    [] => return Err(x.err(node, "'twosided' needs a nested <bsdf>")),
                    _ => {
                        return Err(x.err(
                            node,
                            "'twosided' with different front and back BSDFs is not supported",
                        ));
                    }
                };
                let mut m = self.bsdf(inner, depth + 1)?;
                if let MaterialKind::Dielectric { .. }
                | MaterialKind::TintedDielectric { .. }
                | MaterialKind::ThinDielectric { .. }
                | MaterialKind::RoughDielectric { .. } = m.kind
                {
                    // Mitsuba: "Only materials without a transmission
                    // component can be nested!"
                    return Err(self.xml.err(
                        inner,
                        "'twosided' cannot wrap a transmissive BSDF ('dielectric', 'roughdielectric')",
                    ));
                }
                if let MaterialKind::Principled(p) = &m.kind
                    && p.spec_trans != Texture::Constant(Rgb::ZERO)
                {
                    return Err(self.xml.err(
                        inner,
                        "'twosided' cannot wrap a transmissive BSDF ('principled' with 'spec_trans')",
                    ));
                }
                if m.detail.perturbs_frame() {
                    // Mitsuba's twosided mirrors the directions before the
                    // nested normal map perturbs the frame; ours perturbs
                    // first, which is the other nesting order.
                    return Err(self.xml.err(
                        inner,
                        "'twosided' around 'normalmap'/'bumpmap' is not supported: \
                         put the normal or bump map outside the 'twosided'",
                    ));
                }
                m.two_sided = true;
                m
            }
            "normalmap" | "bumpmap" | "mask" => self.detail_wrapper(&props, node, depth)?,
            // An index-matched boundary between media.
            "null" => Material {
                kind: MaterialKind::Null,
                two_sided: false,
                detail: Default::default(),
            },
            "diffuse" => {
                let reflectance = self.texture_param(&props, "reflectance", Rgb::splat(0.5))?;
                Material {
                    kind: MaterialKind::Diffuse { reflectance },
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "roughdiffuse" => self.rough_diffuse(&props, node)?,
            "conductor" => {
                let fresnel = self.conductor_fresnel(&props)?;
                let specular_reflectance =
                    self.texture_param(&props, "specular_reflectance", Rgb::ONE)?;
                Material {
                    kind: MaterialKind::Conductor {
                        fresnel,
                        specular_reflectance,
                    },
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "roughconductor" => {
                let distribution = self.distribution(&props)?;
                let alpha = self.roughness(&props)?;
                let fresnel = self.conductor_fresnel(&props)?;
                let specular_reflectance =
                    self.texture_param(&props, "specular_reflectance", Rgb::ONE)?;
                // Visible-normal sampling only changes the variance.
                ignored = &["sample_visible"];
                Material {
                    kind: MaterialKind::RoughConductor {
                        distribution,
                        alpha,
                        fresnel,
                        specular_reflectance,
                    },
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "dielectric" | "thindielectric" => {
                let int_ior = self.ior(&props, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&props, "ext_ior", 1.000277)?;
                let specular_reflectance =
                    self.texture_param(&props, "specular_reflectance", Rgb::ONE)?;
                let specular_transmittance =
                    self.texture_param(&props, "specular_transmittance", Rgb::ONE)?;
                // Mitsuba's eta is interior over exterior.
                let eta = int_ior / ext_ior;
                let clear = Texture::Constant(Rgb::ONE);
                let kind = if props.plugin == "thindielectric" {
                    MaterialKind::ThinDielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    }
                } else if specular_reflectance == clear && specular_transmittance == clear {
                    MaterialKind::Dielectric { eta }
                } else {
                    MaterialKind::TintedDielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    }
                };
                Material {
                    kind,
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "plastic" | "roughplastic" => {
                // Mitsuba's defaults: polypropylene in air, base albedo 0.5.
                let int_ior = self.ior(&props, "int_ior", 1.49)?;
                let ext_ior = self.ior(&props, "ext_ior", 1.000277)?;
                let rough = props.plugin == "roughplastic";
                if rough && int_ior == ext_ior {
                    let n = props.get("int_ior").map_or(node, |e| e.node);
                    return Err(self.xml.err(
                        n,
                        "roughplastic: the interior and exterior indices of refraction must differ",
                    ));
                }
                let eta = int_ior / ext_ior;
                let diffuse_reflectance =
                    self.texture_param(&props, "diffuse_reflectance", Rgb::splat(0.5))?;
                let specular_reflectance =
                    self.texture_param(&props, "specular_reflectance", Rgb::ONE)?;
                let nonlinear = props.boolean(&self.xml, "nonlinear")?.unwrap_or(false);
                let kind = if rough {
                    let distribution = self.distribution(&props)?;
                    let alpha = self.roughness(&props)?;
                    // Visible-normal sampling only changes the variance.
                    ignored = &["sample_visible"];
                    MaterialKind::RoughPlastic {
                        distribution,
                        alpha,
                        eta,
                        diffuse_reflectance,
                        specular_reflectance,
                        nonlinear,
                        coating: RoughCoating::new(distribution, alpha, eta),
                    }
                } else {
                    MaterialKind::Plastic {
                        eta,
                        diffuse_reflectance,
                        specular_reflectance,
                        nonlinear,
                    }
                };
                Material {
                    kind,
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "roughdielectric" => {
                let x = &self.xml;
                let distribution = self.distribution(&props)?;
                let alpha = self.roughness(&props)?;
                let int_ior = self.ior(&props, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&props, "ext_ior", 1.000277)?;
                if int_ior == ext_ior {
                    let n = props.get("int_ior").map_or(node, |e| e.node);
                    return Err(x.err(
                        n,
                        format!(
                            "roughdielectric: int_ior and ext_ior must differ (both {int_ior})"
                        ),
                    ));
                }
                let specular_reflectance =
                    self.texture_param(&props, "specular_reflectance", Rgb::ONE)?;
                let specular_transmittance =
                    self.texture_param(&props, "specular_transmittance", Rgb::ONE)?;
                // Visible-normal sampling only changes the variance.
                ignored = &["sample_visible"];
                Material {
                    kind: MaterialKind::RoughDielectric {
                        distribution,
                        alpha,
                        eta: int_ior / ext_ior,
                        specular_reflectance,
                        specular_transmittance,
                    },
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            "principled" => {
                // The sampling rates only change the variance.
                ignored = &[
                    "main_specular_sampling_rate",
                    "clearcoat_sampling_rate",
                    "diffuse_reflectance_sampling_rate",
                ];
                Material {
                    kind: MaterialKind::Principled(self.principled(&props, node)?),
                    two_sided: false,
                    detail: Default::default(),
                }
            }
            other => {
                return Err(self
                    .xml
                    .err(node, format!("unsupported BSDF plugin '{other}'")));
            }
        };
        props.finish(&self.xml, ignored)?;
        if let Err(reason) = m.validate() {
            return Err(self.xml.err(node, format!("invalid BSDF: {reason}")));
        }
        self.bsdf_memo.insert(key(node), m);
        Ok(m)
    }

    /// Mitsuba's surface-detail wrappers `normalmap`, `bumpmap` and `mask`:
    /// the nested BSDF's material with the wrapper's texture in its
    /// [`cmlt::scene::Detail`]. A material takes one of each kind of
    /// wrapper, and a normal map or a bump map, not both.
    fn detail_wrapper(
        &mut self,
        props: &Props<'a>,
        node: Node<'a, 'a>,
        depth: usize,
    ) -> Result<Material, LoadError> {
        let plugin = props.plugin.as_str();
        let nested = props.objects("bsdf");
        let inner = match nested.as_slice() {
            [one] => {
                let Item::Object(n) = one.item else {
                    unreachable!("objects() returns objects")
                };
                n
            }
            [] => {
                return Err(self
                    .xml
                    .err(node, format!("'{plugin}' needs a nested <bsdf>")));
            }
            [_, second, ..] => {
                return Err(self.xml.err(
                    second.node,
                    format!("'{plugin}' takes exactly one nested <bsdf>"),
                ));
            }
        };
        let mut m = self.bsdf(inner, depth + 1)?;
        let x = &self.xml;
        if plugin == "mask" {
            if m.detail.opacity.is_some() {
                return Err(x.err(node, "a 'mask' inside another 'mask' is not supported"));
            }
            let opacity = self.texture_param(props, "opacity", Rgb::splat(0.5))?;
            if let (Texture::Constant(c), Some(e)) = (&opacity, props.get("opacity"))
                && !(0.0..=1.0).contains(&c.luminance())
            {
                return Err(self.xml.err(
                    e.node,
                    format!("mask 'opacity' must lie in [0, 1], got {}", c.luminance()),
                ));
            }
            m.detail.opacity = Some(opacity);
            return Ok(m);
        }
        if m.detail.perturbs_frame() {
            return Err(x.err(
                node,
                format!("'{plugin}' around another normal or bump map is not supported"),
            ));
        }
        // Mitsuba flips a perturbed normal that faces away from the viewer
        // and darkens grazing light with Chiang et al.'s shadow-terminator
        // term; both depend on the directions and are not modelled.
        for flag in ["flip_invalid_normals", "use_shadowing_function"] {
            if props.boolean(x, flag)?.unwrap_or(true) {
                let w = x.warning(
                    node,
                    format!(
                        "'{plugin}': {flag}=true (Mitsuba's default) is not modelled; \
                         the image matches Mitsuba's with {flag}=false"
                    ),
                );
                self.warnings.push(w);
            }
        }
        let textures = props.objects("texture");
        let texture_node = match (plugin, textures.as_slice()) {
            ("normalmap", _) => match props.get("normalmap") {
                Some(Entry {
                    item: Item::Object(n),
                    ..
                }) if n.tag_name().name() == "texture" => *n,
                Some(e) => {
                    return Err(x.err(e.node, "'normalmap' must be a <texture> (a raw bitmap)"));
                }
                None => return Err(x.err(node, "'normalmap' lacks its 'normalmap' texture")),
            },
            (_, [one]) => {
                let Item::Object(n) = one.item else {
                    unreachable!("objects() returns objects")
                };
                n
            }
            (_, []) => return Err(x.err(node, "'bumpmap' needs a nested <texture>")),
            (_, [_, second, ..]) => {
                return Err(x.err(second.node, "'bumpmap' takes exactly one <texture>"));
            }
        };
        let scale = match plugin {
            "bumpmap" => match props.float(x, "scale")? {
                None => 1.0,
                Some((v, n)) if !v.is_finite() => {
                    return Err(x.err(n, format!("bumpmap 'scale' must be finite, got {v}")));
                }
                Some((v, _)) => v as f32,
            },
            _ => 1.0,
        };
        let t = self.texture(texture_node)?;
        if plugin == "normalmap" {
            m.detail.normal_map = Some(t);
        } else {
            m.detail.bump_map = Some(t);
            m.detail.bump_scale = scale;
        }
        Ok(m)
    }

    /// Mitsuba 0.6's `roughdiffuse` (Mitsuba 3 has none): `reflectance`
    /// (default 0.5), `alpha` (RMS slope, default 0.2, a number: a textured
    /// roughness is refused) and `useFastApprox` (default false). 0.6's
    /// alias `diffuseReflectance` is accepted, and each camel-case name
    /// also as Mitsuba 3's upgrade of 0.x files spells it
    /// (`diffuse_reflectance`, `use_fast_approx`).
    fn rough_diffuse(
        &mut self,
        props: &Props<'a>,
        node: Node<'a, 'a>,
    ) -> Result<Material, LoadError> {
        // The one name of `names` the element uses (the first if none).
        let one_of = |names: &[&'static str]| -> Result<&'static str, LoadError> {
            let given: Vec<&str> = names.iter().copied().filter(|n| props.has(n)).collect();
            match given.as_slice() {
                [] => Ok(names[0]),
                [one] => Ok(one),
                [a, b, ..] => Err(self.xml.err(
                    node,
                    format!("roughdiffuse: give '{a}' or '{b}', not both (they are one parameter)"),
                )),
            }
        };
        let refl = one_of(&["reflectance", "diffuse_reflectance", "diffuseReflectance"])?;
        let fast = one_of(&["useFastApprox", "use_fast_approx"])?;
        let reflectance = self.texture_param(props, refl, Rgb::splat(0.5))?;
        let x = &self.xml;
        let alpha = match props.float(x, "alpha")? {
            None => 0.2,
            Some((a, n)) if !(a.is_finite() && (0.0..=MAX_ROUGHNESS as f64).contains(&a)) => {
                return Err(x.err(
                    n,
                    format!("roughdiffuse 'alpha' must be in [0, 1e4], got {a}"),
                ));
            }
            Some((a, _)) => a as f32,
        };
        let fast_approx = props.boolean(x, fast)?.unwrap_or(false);
        Ok(Material {
            kind: MaterialKind::RoughDiffuse {
                reflectance,
                alpha,
                fast_approx,
            },
            two_sided: false,
            detail: Default::default(),
        })
    }

    /// A microfacet `distribution`: `beckmann` (Mitsuba's default) or `ggx`.
    fn distribution(&self, props: &Props<'a>) -> Result<Distribution, LoadError> {
        let x = &self.xml;
        Ok(match props.string(x, "distribution")? {
            None => Distribution::Beckmann,
            Some((d, n)) => match d.to_ascii_lowercase().as_str() {
                "beckmann" => Distribution::Beckmann,
                "ggx" => Distribution::Ggx,
                _ => {
                    return Err(x.err(
                        n,
                        format!("invalid distribution '{d}' (must be 'beckmann' or 'ggx')"),
                    ));
                }
            },
        })
    }

    /// Mitsuba 3's `principled`: its parameter names and defaults
    /// ([`PrincipledParams::DEFAULT`]); every parameter but `eta` and
    /// `specular` may be a texture. Constant values must lie in [0, 1]
    /// (`base_color` per channel). `eta` (> 0) and `specular` (in [0, 1],
    /// η = 2/(1 − √(0.08 specular)) − 1) are alternatives; as in Mitsuba, a
    /// transmitting material (`spec_trans` given and not 0) moves η = 1 to
    /// 1.001 and specular = 0 to 0.001.
    fn principled(
        &mut self,
        props: &Props<'a>,
        node: Node<'a, 'a>,
    ) -> Result<PrincipledParams, LoadError> {
        let d = PrincipledParams::DEFAULT;
        let base_color = self.texture_param(props, "base_color", Rgb::splat(0.5))?;
        if let Texture::Constant(c) = base_color
            && !c.to_array().iter().all(|v| (0.0..=1.0).contains(v))
        {
            let n = props.get("base_color").map_or(node, |e| e.node);
            return Err(self.xml.err(
                n,
                format!("principled: 'base_color' must be in [0, 1], got {c:?}"),
            ));
        }
        let mut scalar = |name: &str, default: f32| -> Result<Texture, LoadError> {
            let t = self.texture_param(props, name, Rgb::splat(default))?;
            let values = match t {
                Texture::Constant(c) => vec![c],
                Texture::Checkerboard { color0, color1, .. } => vec![color0, color1],
                // A grid's voxels are checked when the scene is built.
                Texture::Bitmap { .. } | Texture::Grid(_) => vec![],
            };
            for c in values {
                let v = Texture::scalar(c);
                if !(0.0..=1.0).contains(&v) {
                    let n = props.get(name).map_or(node, |e| e.node);
                    return Err(self.xml.err(
                        n,
                        format!("principled: '{name}' must be in [0, 1], got {v}"),
                    ));
                }
            }
            Ok(t)
        };
        let mut p = PrincipledParams {
            base_color,
            roughness: scalar("roughness", 0.5)?,
            anisotropic: scalar("anisotropic", 0.0)?,
            metallic: scalar("metallic", 0.0)?,
            spec_trans: scalar("spec_trans", 0.0)?,
            spec_tint: scalar("spec_tint", 0.0)?,
            sheen: scalar("sheen", 0.0)?,
            sheen_tint: scalar("sheen_tint", 0.0)?,
            clearcoat: scalar("clearcoat", 0.0)?,
            clearcoat_gloss: scalar("clearcoat_gloss", 0.0)?,
            flatness: scalar("flatness", 0.0)?,
            eta: d.eta,
        };
        // Mitsuba's `get_flag`: given and not the float 0.
        let transmits = p.spec_trans != Texture::Constant(Rgb::ZERO);
        let x = &self.xml;
        p.eta = match (props.float(x, "eta")?, props.float(x, "specular")?) {
            (Some(_), Some((_, n))) => {
                return Err(x.err(n, "principled: give either 'eta' or 'specular', not both"));
            }
            (Some((eta, n)), None) => {
                if !(eta.is_finite() && eta > 0.0) {
                    return Err(x.err(n, format!("principled: 'eta' must be > 0, got {eta}")));
                }
                if transmits && eta == 1.0 {
                    1.001
                } else {
                    eta as f32
                }
            }
            (None, specular) => {
                let (s, n) = specular.unwrap_or((0.5, node));
                if !(0.0..=1.0).contains(&s) {
                    return Err(x.err(
                        n,
                        format!("principled: 'specular' must be in [0, 1], got {s}"),
                    ));
                }
                let s = if transmits && s == 0.0 {
                    1e-3
                } else {
                    s as f32
                };
                PrincipledParams::eta_from_specular(s)
            }
        };
        Ok(p)
    }

    /// `alpha`, or equal `alpha_u`/`alpha_v` (default 0.1, Mitsuba's).
    fn roughness(&self, props: &Props<'a>) -> Result<f32, LoadError> {
        let x = &self.xml;
        let a = props.float(x, "alpha")?;
        let au = props.float(x, "alpha_u")?;
        let av = props.float(x, "alpha_v")?;
        let (alpha, node) = match (a, au, av) {
            (None, None, None) => return Ok(0.1),
            (Some(a), None, None) => a,
            (None, Some(u), Some(v)) => {
                if u.0 != v.0 {
                    return Err(x.err(
                        u.1,
                        "anisotropic roughness (alpha_u != alpha_v) is not supported",
                    ));
                }
                u
            }
            (Some(a), _, _) => {
                return Err(x.err(a.1, "give either 'alpha' or 'alpha_u'/'alpha_v', not both"));
            }
            (None, Some(u), None) => return Err(x.err(u.1, "'alpha_u' needs 'alpha_v' too")),
            (None, None, Some(v)) => return Err(x.err(v.1, "'alpha_v' needs 'alpha_u' too")),
        };
        if !roughness_ok(alpha as f32) {
            return Err(x.err(
                node,
                format!(
                    "roughness alpha must be > 0 and at most {MAX_ROUGHNESS}, got {alpha} \
                     (use 'conductor' for a smooth metal)"
                ),
            ));
        }
        Ok(alpha as f32)
    }

    /// Mitsuba's conductor Fresnel parameters: `eta`/`k` (defaults 0 and 1),
    /// or `material`, one of Mitsuba's named presets as the RGB η and k its
    /// RGB variants give it (`conductor_presets.rs`); `material="none"`
    /// (the default) with no `eta` is an ideal mirror (η = 0 + 1i reflects
    /// everything).
    fn conductor_fresnel(&self, props: &Props<'a>) -> Result<ConductorFresnel, LoadError> {
        let x = &self.xml;
        let material = props.string(x, "material")?;
        let has_eta = props.has("eta") || props.has("k");
        if let Some((name, n)) = &material
            && name != "none"
        {
            if has_eta {
                return Err(x.err(*n, "specify either eta/k or material, not both"));
            }
            let Some((_, eta, k)) = CONDUCTOR_PRESETS.iter().find(|(p, _, _)| p == name) else {
                let names: Vec<&str> = CONDUCTOR_PRESETS.iter().map(|(p, _, _)| *p).collect();
                return Err(x.err(
                    *n,
                    format!(
                        "unknown conductor material preset '{name}' (Mitsuba's presets: none, {})",
                        names.join(", ")
                    ),
                ));
            };
            return Ok(ConductorFresnel::Complex {
                eta: rgb(eta.map(f64::from)),
                k: rgb(k.map(f64::from)),
            });
        }
        let eta = props.color(x, "eta")?;
        let k = props.color(x, "k")?;
        if eta.is_none() && k.is_none() {
            return Ok(ConductorFresnel::Perfect);
        }
        let eta = eta.map_or([0.0; 3], |e| e.0);
        let k = k.map_or([1.0; 3], |e| e.0);
        Ok(ConductorFresnel::Complex {
            eta: rgb(eta),
            k: rgb(k),
        })
    }

    /// An index of refraction given as a number or one of Mitsuba's names.
    fn ior(&self, props: &Props<'a>, name: &str, default: f32) -> Result<f32, LoadError> {
        let x = &self.xml;
        let Some(e) = props.get(name) else {
            return Ok(default);
        };
        let v = match &e.item {
            Item::Value(Value::Float(v)) => *v as f32,
            Item::Value(Value::Integer(v)) => *v as f32,
            Item::Value(Value::String(s)) => {
                let lower = s.to_ascii_lowercase();
                match NAMED_IORS.iter().find(|(n, _)| *n == lower) {
                    Some(&(_, v)) => v,
                    None => {
                        let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
                        return Err(x.err(
                            e.node,
                            format!("unknown IOR name '{s}' (known: {})", names.join(", ")),
                        ));
                    }
                }
            }
            _ => return Err(x.err(e.node, format!("'{name}' must be a float or an IOR name"))),
        };
        if !(v.is_finite() && v > 0.0) {
            return Err(x.err(e.node, format!("'{name}' must be positive, got {v}")));
        }
        Ok(v)
    }

    /// A reflectance-like parameter (an albedo, reflectance, tint or
    /// opacity): a colour, a nested or referenced `<texture>`, or
    /// `default`. Colours must lie in [0, 1] per channel (the rule of
    /// `Material::validate`, located here at the property's line).
    fn texture_param(
        &mut self,
        props: &Props<'a>,
        name: &str,
        default: Rgb,
    ) -> Result<Texture, LoadError> {
        let Some(e) = props.get(name) else {
            return Ok(Texture::Constant(default));
        };
        if let Item::Object(n) = e.item
            && n.tag_name().name() == "texture"
        {
            return self.texture(n);
        }
        let (c, node) = props.color(&self.xml, name)?.expect("entry exists");
        if c.iter().any(|v| *v < 0.0) {
            return Err(self
                .xml
                .err(node, format!("'{name}' must be non-negative, got {c:?}")));
        }
        if c.iter().any(|v| *v > 1.0) {
            // Reflectances above 1 create energy; an opacity is a fraction.
            return Err(self
                .xml
                .err(node, format!("'{name}' must lie in [0, 1], got {c:?}")));
        }
        Ok(Texture::Constant(rgb(c)))
    }

    /// Parses a `<texture>` element (memoised per element).
    pub(crate) fn texture(&mut self, node: Node<'a, 'a>) -> Result<Texture, LoadError> {
        if let Some(t) = self.texture_memo.get(&key(node)) {
            return Ok(*t);
        }
        let props = Props::read(&self.xml, node)?;
        let to_uv = match props.transform(&self.xml, "to_uv")? {
            Some((m, _)) => transform::to_uv(&m),
            None => Affine2::IDENTITY,
        };
        let mut ignored: &[&str] = &[];
        let t = match props.plugin.as_str() {
            "bitmap" => {
                let x = &self.xml;
                let (filename, fnode) = props
                    .string(x, "filename")?
                    .ok_or_else(|| x.err(node, "bitmap texture lacks the 'filename' property"))?;
                let raw = props.boolean(x, "raw")?.unwrap_or(false);
                if let Some((f, n)) = props.string(x, "filter_type")? {
                    match f.as_str() {
                        "bilinear" => {}
                        "nearest" => {
                            let w = x.warning(n, format!("bitmap '{filename}': filter_type 'nearest' is rendered bilinear"));
                            self.warnings.push(w);
                        }
                        _ => {
                            return Err(x.err(
                                n,
                                format!(
                                    "invalid filter_type '{f}' (must be 'bilinear' or 'nearest')"
                                ),
                            ));
                        }
                    }
                }
                if let Some((w, n)) = props.string(x, "wrap_mode")? {
                    match w.as_str() {
                        "repeat" => {}
                        "mirror" | "clamp" => {
                            let msg = x.warning(
                                n,
                                format!(
                                    "bitmap '{filename}': wrap_mode '{w}' is rendered as 'repeat'"
                                ),
                            );
                            self.warnings.push(msg);
                        }
                        _ => return Err(x.err(
                            n,
                            format!(
                                "invalid wrap_mode '{w}' (must be 'repeat', 'mirror' or 'clamp')"
                            ),
                        )),
                    }
                }
                // Storage precision and lookup acceleration do not change
                // what the texture means.
                ignored = &["format", "accel"];
                let id = self.bitmap(&filename, raw, fnode)?;
                Texture::Bitmap { id, to_uv }
            }
            "volume" => {
                // Read at the world position: no uv transform applies.
                if props.has("to_uv") {
                    let n = props.get("to_uv").expect("present").node;
                    return Err(self.xml.err(n, "a 'volume' texture takes no 'to_uv'"));
                }
                let t = self.volume_texture(&props, node)?;
                self.texture_memo.insert(key(node), t);
                return Ok(t);
            }
            "checkerboard" => {
                let x = &self.xml;
                let color = |name: &str, default: f64| -> Result<Rgb, LoadError> {
                    match props.color(x, name)? {
                        None => Ok(Rgb::splat(default as f32)),
                        Some((c, n)) => {
                            if c.iter().any(|v| *v < 0.0) {
                                return Err(x.err(n, format!("'{name}' must be non-negative")));
                            }
                            if c.iter().any(|v| *v > 1.0) {
                                return Err(x.err(n, format!("'{name}' must be at most 1")));
                            }
                            Ok(rgb(c))
                        }
                    }
                };
                // Mitsuba's defaults: 0.4 and 0.2.
                let color0 = color("color0", 0.4)?;
                let color1 = color("color1", 0.2)?;
                Texture::Checkerboard {
                    color0,
                    color1,
                    to_uv,
                }
            }
            other => {
                return Err(self
                    .xml
                    .err(node, format!("unsupported texture plugin '{other}'")));
            }
        };
        props.finish(&self.xml, ignored)?;
        self.texture_memo.insert(key(node), t);
        Ok(t)
    }

    /// Loads an image once per (file, raw) and returns its pending index.
    fn bitmap(
        &mut self,
        filename: &str,
        raw: bool,
        node: Node<'a, 'a>,
    ) -> Result<BitmapId, LoadError> {
        let path: PathBuf = self.base_dir.join(filename);
        let cache_key = (path.clone(), raw);
        if let Some(&i) = self.bitmap_index.get(&cache_key) {
            return Ok(BitmapId(i as u32));
        }
        let b = super::image_io::decode_bitmap(&path, raw)
            .map_err(|e| self.xml.err(node, format!("image file '{filename}': {e}")))?;
        self.bitmaps.push(Pending::new(b));
        let i = self.bitmaps.len() - 1;
        self.bitmap_index.insert(cache_key, i);
        Ok(BitmapId(i as u32))
    }
}
