//! Walking a Mitsuba scene: integrator, sensor, shapes and emitters.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use cmlt::integrator::Settings;
use cmlt::math::Rgb;
use cmlt::scene::{
    Bitmap, BitmapId, Camera, FovAxis, Grid, GridId, Light, Material, MaterialId, MediumId, Mesh,
    SceneBuilder, SceneError, Texture,
};
use glam::{DMat4, DVec3};
use roxmltree::{Document, Node, NodeId, ParsingOptions};

use super::LoadedScene;
use super::bsdf::Pending;
use super::error::LoadError;
use super::mesh_io::{self, RawMesh};
use super::serialized;
use super::shapes;
use super::transform;
use super::xml::{Item, Props, Xml};

/// Mitsuba's default film size (`hdrfilm`).
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;
/// Largest image side we accept (a sanity bound against typos such as an
/// extra zero; Mitsuba has none).
const MAX_RESOLUTION: i64 = 1 << 16;
/// Mitsuba's default far clip, which is also thinlens' default focus distance.
const DEFAULT_FAR_CLIP: f64 = 1e4;

/// State of one load.
pub(crate) struct Loader<'a> {
    pub xml: Xml<'a>,
    pub base_dir: PathBuf,
    pub builder: SceneBuilder,
    pub warnings: Vec<String>,
    pub bsdf_memo: HashMap<NodeId, Material>,
    pub texture_memo: HashMap<NodeId, Texture>,
    pub used_materials: HashMap<NodeId, MaterialId>,
    /// The scene's medium of each `<medium>` element used so far.
    pub used_media: HashMap<NodeId, MediumId>,
    pub default_materials: [Option<MaterialId>; 2],
    pub bitmaps: Vec<Pending<Bitmap, BitmapId>>,
    pub bitmap_index: HashMap<(PathBuf, bool), usize>,
    /// Voxel grids of `volume` textures, added to the scene when used.
    pub grids: Vec<Pending<Grid, GridId>>,
    /// The `<shape>` of each mesh, for mapping `SceneError`s.
    pub mesh_origin: Vec<Node<'a, 'a>>,
    /// The `<bsdf>` of each material (`None` for Mitsuba's default BSDF).
    pub material_origin: Vec<Option<Node<'a, 'a>>>,
}

/// Parses and loads a scene given as text.
pub(crate) fn load(
    text: &str,
    base_dir: &Path,
    file: &str,
    defaults: &[(String, String)],
) -> Result<LoadedScene, LoadError> {
    let options = ParsingOptions {
        allow_dtd: false,
        nodes_limit: 50_000_000,
        ..ParsingOptions::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| {
        let (row, col) = match e {
            // roxmltree reports 1:1 here; the end of the text is where the
            // document was cut off.
            roxmltree::Error::UnexpectedEndOfStream | roxmltree::Error::UnclosedRootNode => {
                end_position(text)
            }
            _ => (e.pos().row, e.pos().col),
        };
        LoadError::at(file, row, col, format!("malformed XML: {e}"))
    })?;
    let xml = Xml::new(&doc, file, defaults)?;
    let l = Loader {
        xml,
        base_dir: base_dir.to_path_buf(),
        builder: SceneBuilder::new(),
        warnings: Vec::new(),
        bsdf_memo: HashMap::new(),
        texture_memo: HashMap::new(),
        used_materials: HashMap::new(),
        used_media: HashMap::new(),
        default_materials: [None, None],
        bitmaps: Vec::new(),
        bitmap_index: HashMap::new(),
        grids: Vec::new(),
        mesh_origin: Vec::new(),
        material_origin: Vec::new(),
    };
    l.scene(doc.root_element())
}

impl<'a> Loader<'a> {
    fn scene(mut self, root: Node<'a, 'a>) -> Result<LoadedScene, LoadError> {
        let x = &self.xml;
        if root.tag_name().name() != "scene" {
            return Err(x.err(
                root,
                format!(
                    "the root element must be <scene>, found <{}>",
                    root.tag_name().name()
                ),
            ));
        }
        let version = x
            .attr(root, "version")?
            .ok_or_else(|| x.err(root, "<scene> lacks the required 'version' attribute"))?;
        let major: Option<u32> = version
            .split('.')
            .next()
            .and_then(|m| m.trim().parse().ok());
        match major {
            Some(2 | 3) => {}
            Some(0 | 1) => {
                return Err(x.err(
                    root,
                    format!("scene version {version} uses the Mitsuba 0.x format; only version 2.x/3.x scenes are supported"),
                ));
            }
            _ => return Err(x.err(root, format!("unsupported scene version '{version}'"))),
        }

        let mut integrator: Option<(String, Settings, Node)> = None;
        let mut sensor: Option<(Camera, Option<u32>)> = None;
        let mut top_bsdfs = Vec::new();
        let mut top_textures = Vec::new();
        for child in root.children().filter(|n| n.is_element()) {
            let tag = child.tag_name().name();
            match tag {
                "default" => {}
                "integrator" => {
                    if let Some((_, _, first)) = &integrator {
                        let (l, c) = self.xml.pos(*first);
                        return Err(self.xml.err(
                            child,
                            format!(
                                "only one <integrator> is allowed (first at line {l}, column {c})"
                            ),
                        ));
                    }
                    let (ty, s) = self.integrator(child)?;
                    integrator = Some((ty, s, child));
                }
                "sensor" => {
                    if sensor.is_some() {
                        let w = self.xml.warning(
                            child,
                            "more than one <sensor>: rendering the first, like Mitsuba",
                        );
                        self.warnings.push(w);
                        continue;
                    }
                    sensor = Some(self.sensor(child)?);
                }
                "bsdf" => top_bsdfs.push(child),
                "texture" => top_textures.push(child),
                "shape" => self.shape(child)?,
                "emitter" => {
                    let ty = self.xml.attr(child, "type")?.unwrap_or_default();
                    if ty == "area" {
                        return Err(self
                            .xml
                            .err(child, "an 'area' emitter must be nested inside a <shape>"));
                    }
                    if ty == "sunsky" {
                        for light in self.sunsky(child)? {
                            self.builder.add_light(light);
                        }
                    } else {
                        let light = self.scene_emitter(child)?;
                        self.builder.add_light(light);
                    }
                }
                // Mitsuba instantiates every top-level object: an unused
                // medium must be valid too (it changes no image).
                "medium" => {
                    self.use_medium(child)?;
                }
                "phase" => {
                    return Err(self
                        .xml
                        .err(child, "a <phase> must be nested inside a <medium>"));
                }
                // Read when a texture uses it; instantiated (and so
                // validated) here like every top-level object.
                "volume" => {
                    self.volume(child)?;
                }
                "include" | "path" | "alias" => {
                    return Err(self.xml.err(
                        child,
                        format!("<{tag}> is not supported by cmlt's scene loader"),
                    ));
                }
                "film" | "sampler" | "rfilter" => {
                    return Err(self
                        .xml
                        .err(child, format!("<{tag}> must be nested inside a <sensor>")));
                }
                "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point"
                | "vector" | "transform" | "ref" => {
                    return Err(self
                        .xml
                        .err(child, format!("unexpected <{tag}> directly inside <scene>")));
                }
                other => {
                    return Err(self
                        .xml
                        .err(child, format!("unknown XML element <{other}>")));
                }
            }
        }
        // Mitsuba instantiates every top-level object, so unused BSDFs and
        // textures must be valid too (they are not added to the scene).
        for b in top_bsdfs {
            self.bsdf(b, 0)?;
        }
        for t in top_textures {
            self.texture(t)?;
        }
        let Some((camera, spp)) = sensor else {
            return Err(self.xml.err(
                root,
                "the scene has no <sensor> (cmlt needs a perspective or thinlens camera)",
            ));
        };
        self.builder.set_camera(camera);
        for p in self.xml.unused_command_line_params() {
            self.warnings.push(format!(
                "{}: warning: parameter '{p}' given on the command line is not used by the scene",
                self.xml.file
            ));
        }
        let (integrator, settings) = match integrator {
            Some((ty, s, _)) => (ty, s),
            // Mitsuba renders with `path` and its defaults when the scene
            // names no integrator.
            None => ("path".to_string(), Settings::default()),
        };
        let Loader {
            builder,
            mesh_origin,
            material_origin,
            xml,
            warnings,
            ..
        } = self;
        let scene = builder
            .build()
            .map_err(|e| scene_error(&xml, &mesh_origin, &material_origin, e))?;
        Ok(LoadedScene {
            scene,
            settings,
            spp,
            integrator,
            warnings,
        })
    }

    /// `<integrator>`: records the type and Mitsuba's path-tracer settings.
    fn integrator(&mut self, node: Node<'a, 'a>) -> Result<(String, Settings), LoadError> {
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        let mut s = Settings::default();
        if let Some((d, n)) = props.integer(x, "max_depth")? {
            s.max_depth = match d {
                -1 => None,
                0.. if d <= u32::MAX as i64 => Some(d as u32),
                _ => {
                    return Err(x.err(
                        n,
                        format!("max_depth must be -1 (unbounded) or a depth >= 0, got {d}"),
                    ));
                }
            };
        }
        if let Some((d, n)) = props.integer(x, "rr_depth")? {
            if !(1..=u32::MAX as i64).contains(&d) {
                return Err(x.err(n, format!("rr_depth must be > 0, got {d}")));
            }
            s.rr_depth = d as u32;
        }
        if let Some(h) = props.boolean(x, "hide_emitters")? {
            s.hide_emitters = h;
        }
        // The CLI chooses the rendering method; other integrator parameters
        // (and integrator types) are reported, not rejected.
        for (name, n) in props.unused() {
            let w = x.warning(
                n,
                format!(
                    "integrator parameter '{name}' of '{}' is ignored",
                    props.plugin
                ),
            );
            self.warnings.push(w);
        }
        Ok((props.plugin.clone(), s))
    }

    /// `<sensor type="perspective|thinlens">` with its film and sampler.
    fn sensor(&mut self, node: Node<'a, 'a>) -> Result<(Camera, Option<u32>), LoadError> {
        let props = Props::read(&self.xml, node)?;
        let thinlens = match props.plugin.as_str() {
            "perspective" => false,
            "thinlens" => true,
            other => {
                return Err(self
                    .xml
                    .err(node, format!("unsupported sensor plugin '{other}'")));
            }
        };
        let films = props.objects("film");
        let (width, height) = match films.as_slice() {
            [] => {
                let w = self.xml.warning(node, "sensor has no <film>: using Mitsuba's default 768x576 hdrfilm with a box filter");
                self.warnings.push(w);
                (DEFAULT_WIDTH as u32, DEFAULT_HEIGHT as u32)
            }
            [f] => {
                let Item::Object(n) = f.item else {
                    unreachable!()
                };
                self.film(n)?
            }
            [_, second, ..] => {
                return Err(self
                    .xml
                    .err(second.node, "only one <film> per sensor is allowed"));
            }
        };
        let medium = self.sensor_medium(&props)?;
        self.builder.set_camera_medium(medium);
        let samplers = props.objects("sampler");
        let spp = match samplers.as_slice() {
            [] => None,
            [s] => {
                let Item::Object(n) = s.item else {
                    unreachable!()
                };
                self.sampler(n)?
            }
            [_, second, ..] => {
                return Err(self
                    .xml
                    .err(second.node, "only one <sampler> per sensor is allowed"));
            }
        };

        let x = &self.xml;
        let to_world = match props.transform(x, "to_world")? {
            None => DMat4::IDENTITY,
            Some((m, n)) => {
                if !transform::is_affine(&m) {
                    return Err(x.err(n, "camera to_world must be affine (last row 0 0 0 1)"));
                }
                if transform::linear(&m).determinant().abs() < 1e-12 {
                    return Err(x.err(n, "camera to_world is singular"));
                }
                if transform::has_scale(&m) {
                    // Mitsuba 3 refuses these; scenes written by older
                    // exporters carry them (Bitterli's bedroom: a mirror
                    // with a 1.5° shear). The camera keeps the transform's
                    // rigid part, orthonormalised around its viewing
                    // direction with any mirror kept (`Camera::perspective`);
                    // the fov stays what the scene gives.
                    let w = x.warning(
                        n,
                        format!(
                            "camera to_world has scale or shear (|M·Mᵀ − I| up to {:.3}): \
                             only its rotation and mirroring are used (Mitsuba 3 refuses it)",
                            transform::scale_deviation(&m)
                        ),
                    );
                    self.warnings.push(w);
                }
                m
            }
        };
        let fov_given = props.float(x, "fov")?;
        let focal = props.string(x, "focal_length")?;
        let (fov, axis) = match (fov_given, focal) {
            (Some(_), Some((_, n))) => {
                return Err(x.err(n, "give either 'fov' or 'focal_length', not both"));
            }
            (Some((f, n)), None) => {
                if !(f > 0.0 && f < 180.0) {
                    return Err(x.err(n, format!("fov must be in (0, 180) degrees, got {f}")));
                }
                let axis = match props.string(x, "fov_axis")? {
                    None => FovAxis::X,
                    Some((a, an)) => match a.to_ascii_lowercase().as_str() {
                        "x" => FovAxis::X,
                        "y" => FovAxis::Y,
                        "diagonal" => FovAxis::Diagonal,
                        "smaller" => FovAxis::Smaller,
                        "larger" => FovAxis::Larger,
                        _ => {
                            return Err(x.err(
                                an,
                                format!(
                                    "invalid fov_axis '{a}' (x, y, diagonal, smaller or larger)"
                                ),
                            ));
                        }
                    },
                };
                (f, axis)
            }
            (None, focal) => {
                // Mitsuba's 35 mm equivalent: fov along the diagonal of a
                // 36 × 24 mm frame, 50 mm by default.
                let (text, n) = focal.unwrap_or_else(|| ("50mm".to_string(), node));
                let num = text.trim().strip_suffix("mm").unwrap_or(text.trim());
                let f = super::xml::parse_f64(num)
                    .ok()
                    .filter(|f| *f > 0.0)
                    .ok_or_else(|| {
                        x.err(
                            n,
                            format!("invalid focal_length '{text}' (expected e.g. \"50mm\")"),
                        )
                    })?;
                let fov = 2.0
                    * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * f))
                        .atan()
                        .to_degrees();
                (fov, FovAxis::Diagonal)
            }
        };
        let far_clip = props.float(x, "far_clip")?;
        let near_clip = props.float(x, "near_clip")?;
        if let Some((_, n)) = near_clip.or(far_clip) {
            let w = x.warning(
                n,
                "near_clip/far_clip are not applied (cmlt does not clip camera rays)",
            );
            self.warnings.push(w);
        }
        let x = &self.xml;
        let (aperture, focus) = if thinlens {
            let (a, an) = props.float(x, "aperture_radius")?.ok_or_else(|| {
                x.err(node, "thinlens sensor lacks the 'aperture_radius' property")
            })?;
            if a < 0.0 {
                return Err(x.err(an, format!("aperture_radius must be >= 0, got {a}")));
            }
            let focus = match props.float(x, "focus_distance")? {
                Some((f, n)) if f <= 0.0 => {
                    return Err(x.err(n, format!("focus_distance must be > 0, got {f}")));
                }
                Some((f, _)) => f,
                None => far_clip.map_or(DEFAULT_FAR_CLIP, |f| f.0),
            };
            (a, focus)
        } else {
            // Mitsuba reads `focus_distance` for every projective camera
            // (default: far_clip), and a pinhole has no focal plane, so the
            // value cannot change the image: accept it like Mitsuba, but
            // refuse a distance no camera could focus at.
            if let Some((f, n)) = props.float(x, "focus_distance")?
                && f <= 0.0
            {
                return Err(x.err(n, format!("focus_distance must be > 0, got {f}")));
            }
            (0.0, 1.0)
        };
        props.finish(x, &[])?;
        let camera = Camera::perspective(
            transform::to_f32(&to_world),
            fov as f32,
            axis,
            width,
            height,
            aperture as f32,
            focus as f32,
        )
        .map_err(|e| x.err(node, format!("invalid camera: {e}")))?;
        Ok((camera, spp))
    }

    /// `<film type="hdrfilm">`: the resolution; warns about filters other
    /// than `box` (cmlt always reconstructs with a box filter).
    fn film(&mut self, node: Node<'a, 'a>) -> Result<(u32, u32), LoadError> {
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        if props.plugin != "hdrfilm" {
            return Err(x.err(node, format!("unsupported film plugin '{}'", props.plugin)));
        }
        let side = |name: &str, default: i64| -> Result<u32, LoadError> {
            match props.integer(x, name)? {
                None => Ok(default as u32),
                Some((v, _)) if (1..=MAX_RESOLUTION).contains(&v) => Ok(v as u32),
                Some((v, n)) => Err(x.err(
                    n,
                    format!("film {name} must be in 1..={MAX_RESOLUTION}, got {v}"),
                )),
            }
        };
        let width = side("width", DEFAULT_WIDTH)?;
        let height = side("height", DEFAULT_HEIGHT)?;
        let filters = props.objects("rfilter");
        match filters.as_slice() {
            [] => {
                let w = x.warning(node, "film has no <rfilter>: Mitsuba's default is 'gaussian', cmlt renders with a box filter");
                self.warnings.push(w);
            }
            [f] => {
                let Item::Object(n) = f.item else {
                    unreachable!()
                };
                let ty = x.attr(n, "type")?.unwrap_or_default();
                if ty != "box" {
                    let w = x.warning(n, format!("reconstruction filter '{ty}' is not implemented: rendering with a box filter"));
                    self.warnings.push(w);
                }
            }
            [_, second, ..] => {
                return Err(x.err(second.node, "only one <rfilter> per film is allowed"));
            }
        }
        // Output-format details do not change the image; `sample_border`
        // has no effect with a box filter.
        props.finish(
            x,
            &[
                "file_format",
                "pixel_format",
                "component_format",
                "banner",
                "compensate",
                "sample_border",
            ],
        )?;
        Ok((width, height))
    }

    /// `<sampler>`: only `sample_count` matters (the pattern changes noise,
    /// not the expected image).
    fn sampler(&mut self, node: Node<'a, 'a>) -> Result<Option<u32>, LoadError> {
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        let spp = match props.integer(x, "sample_count")? {
            None => None,
            Some((v, n)) => {
                if !(1..=u32::MAX as i64).contains(&v) {
                    return Err(x.err(n, format!("sample_count must be >= 1, got {v}")));
                }
                Some(v as u32)
            }
        };
        if props.plugin != "independent" {
            let w = x.warning(
                node,
                format!(
                    "sampler '{}' is replaced by cmlt's own sample streams",
                    props.plugin
                ),
            );
            self.warnings.push(w);
        }
        Ok(spp)
    }

    /// A colour property of an emitter (`default` when absent), refused
    /// when negative or not finite.
    fn emitter_power(&self, props: &Props<'a>, name: &str, default: f64) -> Result<Rgb, LoadError> {
        let x = &self.xml;
        if let Some(e) = props.get(name)
            && let Item::Object(_) = e.item
        {
            return Err(x.err(
                e.node,
                format!("a textured '{name}' is not supported (give an <rgb> value)"),
            ));
        }
        let Some((c, n)) = props.color(x, name)? else {
            return Ok(Rgb::splat(default as f32));
        };
        let v = Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32);
        if c.iter().any(|v| *v < 0.0) || !v.is_finite() {
            return Err(x.err(
                n,
                format!("{name} must be finite and non-negative, got {c:?}"),
            ));
        }
        Ok(v)
    }

    /// A scene-level `<emitter>`: Mitsuba 3's `point`, `spot`,
    /// `directional`, `constant` or `envmap` (`filename`, `scale`,
    /// `to_world`), with Mitsuba's defaults (power 1, a
    /// spot's cutoff 20° and beam width 3/4 of it; `to_world` places a
    /// point light at its origin and aims a spot or sun along its +z).
    fn scene_emitter(&mut self, node: Node<'a, 'a>) -> Result<Light, LoadError> {
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        let to_world = props.transform(x, "to_world")?;
        let origin = to_world
            .map(|(m, _)| m.transform_point3(DVec3::ZERO))
            .unwrap_or(DVec3::ZERO);
        let axis = to_world
            .map(|(m, _)| m.transform_vector3(DVec3::Z))
            .unwrap_or(DVec3::Z);
        let v3 = |v: DVec3| glam::Vec3::new(v.x as f32, v.y as f32, v.z as f32);
        let exclusive = |a: &str, b: &str| -> Result<(), LoadError> {
            match (props.get(a), props.get(b)) {
                (Some(e), Some(_)) => {
                    Err(x.err(e.node, format!("give either '{a}' or '{b}', not both")))
                }
                _ => Ok(()),
            }
        };
        let light = match props.plugin.as_str() {
            "point" => {
                exclusive("position", "to_world")?;
                let position = props
                    .vector(x, "position")?
                    .map(DVec3::from)
                    .unwrap_or(origin);
                Light::Point {
                    position: v3(position),
                    intensity: self.emitter_power(&props, "intensity", 1.0)?,
                }
            }
            "spot" => {
                let cutoff = props.float(x, "cutoff_angle")?.map_or(20.0, |(v, _)| v);
                let beam = props
                    .float(x, "beam_width")?
                    .map_or(cutoff * 0.75, |(v, _)| v);
                Light::Spot {
                    position: v3(origin),
                    direction: v3(axis),
                    intensity: self.emitter_power(&props, "intensity", 1.0)?,
                    cutoff_angle: cutoff as f32,
                    beam_width: beam as f32,
                }
            }
            "directional" => {
                exclusive("direction", "to_world")?;
                let direction = props
                    .vector(x, "direction")?
                    .map(DVec3::from)
                    .unwrap_or(axis);
                Light::Directional {
                    direction: v3(direction),
                    irradiance: self.emitter_power(&props, "irradiance", 1.0)?,
                }
            }
            "constant" => Light::Constant {
                radiance: self.emitter_power(&props, "radiance", 1.0)?,
            },
            "envmap" => {
                let (filename, fnode) = props
                    .string(x, "filename")?
                    .ok_or_else(|| x.err(node, "envmap emitter lacks the 'filename' property"))?;
                let scale = match props.float(x, "scale")? {
                    None => 1.0,
                    Some((v, n)) if !(v.is_finite() && v >= 0.0) => {
                        return Err(x.err(
                            n,
                            format!("'scale' must be finite and non-negative, got {v}"),
                        ));
                    }
                    Some((v, _)) => v as f32,
                };
                // Mitsuba's envmap decodes 8-bit images with the sRGB curve
                // (`convert(RGB, Float, srgb=false)`); float images are
                // linear.
                let path = self.base_dir.join(&filename);
                let bitmap = super::image_io::decode_bitmap(&path, false)
                    .map_err(|e| x.err(fnode, format!("image file '{filename}': {e}")))?;
                // A light at infinity: only the rotation part matters.
                let to_world = to_world
                    .map(|(m, _)| glam::DMat3::from_mat4(m).as_mat3())
                    .unwrap_or(glam::Mat3::IDENTITY);
                Light::Envmap {
                    bitmap: self.builder.add_bitmap(bitmap),
                    scale,
                    to_world,
                }
            }
            other => {
                return Err(x.err(
                    node,
                    format!(
                        "unsupported emitter plugin '{other}' (cmlt supports point, spot, directional, constant, envmap and sunsky, and area emitters on shapes)"
                    ),
                ));
            }
        };
        light.validate().map_err(|reason| x.err(node, reason))?;
        // MIS compensation changes how an envmap is sampled, not the image.
        props.finish(x, &["mis_compensation"])?;
        Ok(light)
    }

    /// `<emitter type="sunsky">` (Mitsuba 3's parameters and defaults, see
    /// [`super::sunsky`]): the sky baked into an environment map and the
    /// sun's disc; none when the sun is below the horizon.
    fn sunsky(&mut self, node: Node<'a, 'a>) -> Result<Vec<Light>, LoadError> {
        use super::sunsky::{SunSky, TimePlace};
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        let float_in = |name: &str, default: f64, ok: &dyn Fn(f64) -> bool, range: &str| match props
            .float(x, name)?
        {
            None => Ok(default),
            Some((v, n)) if !(v.is_finite() && ok(v)) => {
                Err(x.err(n, format!("sunsky: '{name}' must be {range}, got {v}")))
            }
            Some((v, _)) => Ok(v),
        };
        let turbidity = float_in(
            "turbidity",
            3.0,
            &|v| (1.0..=10.0).contains(&v),
            "in [1, 10]",
        )?;
        let sun_scale = float_in("sun_scale", 1.0, &|v| v >= 0.0, "non-negative")?;
        let sky_scale = float_in("sky_scale", 1.0, &|v| v >= 0.0, "non-negative")?;
        let sun_aperture = float_in(
            "sun_aperture",
            0.5358,
            &|v| v > 0.0 && v < 180.0,
            "in (0, 180) degrees",
        )?;
        let albedo = match props.get("albedo") {
            Some(e) if matches!(e.item, Item::Object(_)) => {
                return Err(x.err(
                    e.node,
                    "sunsky: the albedo cannot be a texture (give an <rgb> or <float> value)",
                ));
            }
            _ => match props.color(x, "albedo")? {
                None => [0.3; 3],
                Some((c, n)) => {
                    if !c.iter().all(|v| (0.0..=1.0).contains(v)) {
                        return Err(x.err(
                            n,
                            format!("sunsky: 'albedo' must be in [0, 1] per channel, got {c:?}"),
                        ));
                    }
                    c
                }
            },
        };
        let complex_sun = props.boolean(x, "complex_sun")?.unwrap_or(false);
        let to_world = match props.transform(x, "to_world")? {
            None => glam::DMat3::IDENTITY,
            Some((m, n)) => {
                let r = glam::DMat3::from_mat4(m);
                if !(r.is_finite() && (r.transpose() * r).abs_diff_eq(glam::DMat3::IDENTITY, 1e-3))
                {
                    return Err(x.err(
                        n,
                        "sunsky: to_world must be a rotation (orthonormal, no scaling or shear)",
                    ));
                }
                r
            }
        };
        const TIME: [&str; 9] = [
            "latitude",
            "longitude",
            "timezone",
            "year",
            "month",
            "day",
            "hour",
            "minute",
            "second",
        ];
        let sun_local = if props.has("sun_direction") {
            if let Some(t) = TIME.iter().find(|t| props.has(t)) {
                let n = props.get(t).map_or(node, |e| e.node);
                return Err(x.err(
                    n,
                    format!("sunsky: give either 'sun_direction' or the time and place ('{t}'), not both"),
                ));
            }
            let d = glam::DVec3::from(props.vector(x, "sun_direction")?.unwrap_or_default());
            if !(d.is_finite() && d.length_squared() > 0.0) {
                let n = props.get("sun_direction").map_or(node, |e| e.node);
                return Err(x.err(n, "sunsky: 'sun_direction' must be finite and non-zero"));
            }
            (to_world.transpose() * d).normalize()
        } else {
            let dflt = TimePlace::default();
            let f = |name: &str, default: f64| float_in(name, default, &|_| true, "finite");
            let int = |name: &str, default: i64, lo: i64, hi: i64| match props.integer(x, name)? {
                None => Ok(default),
                Some((v, n)) if !(lo..=hi).contains(&v) => Err(x.err(
                    n,
                    format!("sunsky: '{name}' must be in [{lo}, {hi}], got {v}"),
                )),
                Some((v, _)) => Ok(v),
            };
            let t = TimePlace {
                latitude: float_in(
                    "latitude",
                    dflt.latitude,
                    &|v| v.abs() <= 90.0,
                    "in [-90, 90]",
                )?,
                longitude: f("longitude", dflt.longitude)?,
                timezone: f("timezone", dflt.timezone)?,
                year: int("year", dflt.year, -4000, 10000)?,
                month: int("month", dflt.month, 1, 12)?,
                day: int("day", dflt.day, 1, 31)?,
                hour: f("hour", dflt.hour)?,
                minute: f("minute", dflt.minute)?,
                second: f("second", dflt.second)?,
            };
            super::sunsky::sun_from_time(&t)
        };
        props.finish(x, &[])?;
        if sun_local.z < 0.0 {
            // Mitsuba 3 warns too; a y-up 0.6 scene needs a to_world.
            let w = x.warning(
                node,
                "sunsky: the sun is below the horizon of the emitter's z-up frame, so the sky and sun are black",
            );
            self.warnings.push(w);
        }
        let s = SunSky {
            turbidity,
            albedo,
            sun_local,
            sun_scale,
            sky_scale,
            sun_aperture,
            complex_sun,
            to_world,
        };
        let lights = super::sunsky::lights(&s, &mut |b| self.builder.add_bitmap(b));
        for l in &lights {
            l.validate().map_err(|reason| self.xml.err(node, reason))?;
        }
        Ok(lights)
    }

    /// `<emitter type="area">` inside a shape: its radiance, `None` if black.
    fn area_emitter(&mut self, node: Node<'a, 'a>) -> Result<Option<Rgb>, LoadError> {
        let props = Props::read(&self.xml, node)?;
        let x = &self.xml;
        if props.plugin != "area" {
            return Err(x.err(
                node,
                format!(
                    "unsupported emitter plugin '{}' (cmlt supports 'area' only)",
                    props.plugin
                ),
            ));
        }
        if let Some(e) = props.get("radiance")
            && let Item::Object(_) = e.item
        {
            return Err(x.err(
                e.node,
                "textured radiance is not supported (give an <rgb> value)",
            ));
        }
        let (c, n) = props
            .color(x, "radiance")?
            .ok_or_else(|| x.err(node, "area emitter lacks the 'radiance' property"))?;
        if c.iter().any(|v| *v < 0.0) {
            return Err(x.err(n, format!("radiance must be non-negative, got {c:?}")));
        }
        let le = Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32);
        if !le.is_finite() {
            return Err(x.err(n, "radiance is out of range"));
        }
        props.finish(x, &[])?;
        // A black emitter emits nothing; leaving it out keeps the light
        // set free of zero-power lights.
        Ok((!le.is_black()).then_some(le))
    }

    /// `<shape>`: one mesh in the scene.
    fn shape(&mut self, node: Node<'a, 'a>) -> Result<(), LoadError> {
        let props = Props::read(&self.xml, node)?;
        let emitters = props.objects("emitter");
        let emission = match emitters.as_slice() {
            [] => None,
            [e] => {
                let Item::Object(n) = e.item else {
                    unreachable!()
                };
                self.area_emitter(n)?
            }
            [_, second, ..] => {
                return Err(self
                    .xml
                    .err(second.node, "only one <emitter> per shape is allowed"));
            }
        };
        let bsdfs = props.objects("bsdf");
        let material = match bsdfs.as_slice() {
            [] => self.default_material(!emitters.is_empty()),
            [b] => {
                let Item::Object(n) = b.item else {
                    unreachable!()
                };
                self.use_bsdf(n)?
            }
            [_, second, ..] => {
                return Err(self
                    .xml
                    .err(second.node, "only one <bsdf> per shape is allowed"));
            }
        };

        let media = self.shape_media(&props)?;
        let x = &self.xml;
        let (to_world, tnode) = props
            .transform(x, "to_world")?
            .unwrap_or((DMat4::IDENTITY, node));
        let mut flip = props.boolean(x, "flip_normals")?.unwrap_or(false);
        let face_normals = props.boolean(x, "face_normals")?.unwrap_or(false);
        let at_transform = |e: String| x.err(tnode, e);
        let mut ignored: &[&str] = &[];
        let mesh = match props.plugin.as_str() {
            kind @ ("obj" | "ply" | "serialized") => {
                let (filename, fnode) = props.string(x, "filename")?.ok_or_else(|| {
                    x.err(node, format!("{kind} shape lacks the 'filename' property"))
                })?;
                let path = self.base_dir.join(&filename);
                let file_err = |e: String| x.err(fnode, format!("mesh file '{filename}': {e}"));
                let raw = match kind {
                    "obj" => {
                        let flip_tex = props.boolean(x, "flip_tex_coords")?.unwrap_or(true);
                        mesh_io::read_obj(&path, flip_tex).map_err(file_err)?
                    }
                    "ply" => mesh_io::read_ply(&path).map_err(file_err)?,
                    _ => {
                        let index = match props.integer(x, "shape_index")? {
                            None => 0,
                            Some((i, n)) => u32::try_from(i).map_err(|_| {
                                x.err(n, format!("shape_index must be non-negative, got {i}"))
                            })?,
                        };
                        serialized::read_serialized(&path, index).map_err(file_err)?
                    }
                };
                // Mitsuba never re-winds file meshes (see `shapes`).
                let mut m = shapes::place(&raw, &to_world, false).map_err(at_transform)?;
                if face_normals {
                    m.normals.clear();
                } else if m.normals.is_empty() {
                    shapes::recompute_normals(&mut m);
                }
                m
            }
            builtin @ ("rectangle" | "cube" | "disk") => {
                // Planar and box shapes look the same either way.
                ignored = &["face_normals"];
                let raw: RawMesh = match builtin {
                    "rectangle" => shapes::rectangle(),
                    "cube" => shapes::cube(),
                    _ => shapes::disk(),
                };
                shapes::place(&raw, &to_world, true).map_err(at_transform)?
            }
            "sphere" => {
                ignored = &["face_normals"];
                let radius = match props.float(x, "radius")? {
                    None => 1.0,
                    Some((r, n)) => {
                        // A negative radius turns the sphere inside out, as
                        // in Mitsuba; zero would be a point.
                        if r == 0.0 {
                            return Err(x.err(n, "sphere radius must not be zero"));
                        }
                        r
                    }
                };
                let center = DVec3::from(props.vector(x, "center")?.unwrap_or([0.0; 3]));
                if !transform::is_affine(&to_world) {
                    return Err(x.err(tnode, "to_world must be affine (last row 0 0 0 1)"));
                }
                // Mitsuba: to_world · translate(center) · scale(radius).
                let m = to_world
                    * DMat4::from_translation(center)
                    * DMat4::from_scale(DVec3::splat(radius));
                let (place, inverted, distorted) =
                    shapes::sphere_placement(&m).map_err(|e| x.err(node, e))?;
                if distorted {
                    let w = x.warning(
                        tnode,
                        "sphere to_world has shear or non-uniform scale: ignored, as Mitsuba does",
                    );
                    self.warnings.push(w);
                }
                flip ^= inverted;
                shapes::place(shapes::sphere_unit_exact(), &place, true)
                    .map_err(|e| x.err(node, e))?
            }
            other => return Err(x.err(node, format!("unsupported shape plugin '{other}'"))),
        };
        let x = &self.xml;
        props.finish(x, ignored)?;
        let mut mesh = mesh;
        if flip {
            shapes::flip(&mut mesh);
        }
        let w = shapes::to_world_mesh(mesh).map_err(|e| x.err(node, e))?;
        let mesh = self.builder.add_mesh(Mesh {
            positions: w.positions,
            normals: w.normals,
            uvs: w.uvs,
            indices: w.indices,
            material,
            emission,
        });
        if media.is_transition() {
            self.builder.set_mesh_media(mesh, media);
        }
        self.mesh_origin.push(node);
        Ok(())
    }
}

/// 1-based line and column just after the last character of `text`.
fn end_position(text: &str) -> (u32, u32) {
    let line = text.matches('\n').count() as u32 + 1;
    let last = text.rsplit('\n').next().unwrap_or("");
    (line, last.chars().count() as u32 + 1)
}

/// Turns a `SceneBuilder` error into one located at the offending element.
fn scene_error(xml: &Xml, meshes: &[Node], materials: &[Option<Node>], e: SceneError) -> LoadError {
    let at_mesh = |mesh: usize, what: String| match meshes.get(mesh) {
        Some(&n) => xml.err(n, format!("{}: {what}", xml.describe(n))),
        None => LoadError::whole_file(xml.file, what),
    };
    match e {
        SceneError::NonFiniteVertex { mesh, vertex } => at_mesh(
            mesh,
            format!("vertex {vertex} has a non-finite position, normal or uv"),
        ),
        SceneError::IndexOutOfRange { mesh, triangle } => at_mesh(
            mesh,
            format!("triangle {triangle} refers to a vertex that does not exist"),
        ),
        SceneError::InvalidEmission { mesh } => at_mesh(
            mesh,
            "emitted radiance must be finite and non-negative".into(),
        ),
        SceneError::InvalidMaterial { material, reason } => {
            match materials.get(material).copied().flatten() {
                Some(n) => xml.err(n, format!("invalid BSDF: {reason}")),
                None => LoadError::whole_file(xml.file, format!("invalid default BSDF: {reason}")),
            }
        }
        other => LoadError::whole_file(xml.file, format!("invalid scene: {other}")),
    }
}
