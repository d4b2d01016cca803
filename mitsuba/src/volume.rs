//! Mitsuba 3's `volume` texture: a surface reads a volume at its world
//! position. `constvolume` is a constant texture; `gridvolume` is a voxel
//! grid from a `.vol` file (`vol.rs`) placed by `to_world` over the unit
//! cube (or, with `use_grid_bbox`, over the file's bounding box), with
//! `filter_type` and `wrap_mode` as Mitsuba 3 reads them.

use std::path::PathBuf;

use glam::{Affine3A, DMat4, DVec3};
use roxmltree::Node;

use cmlt::math::Rgb;
use cmlt::scene::{Grid, GridFilter, GridId, GridWrap, Texture};

use super::bsdf::Pending;
use super::error::LoadError;
use super::input::{self, MAX_GRID_BYTES};
use super::loader::Loader;
use super::transform;
use super::xml::{Item, Props, key};

impl<'a> Loader<'a> {
    /// The texture of a `<texture type="volume">` (its properties
    /// `props`): the nested `<volume name="volume">`.
    pub(crate) fn volume_texture(
        &mut self,
        props: &Props<'a>,
        node: Node<'a, 'a>,
    ) -> Result<Texture, LoadError> {
        let x = &self.xml;
        let Some(e) = props.get("volume") else {
            return Err(x.err(
                node,
                "a 'volume' texture needs a nested <volume name=\"volume\">",
            ));
        };
        let Item::Object(v) = e.item else {
            return Err(x.err(e.node, "'volume' must be a <volume> object"));
        };
        if v.tag_name().name() != "volume" {
            return Err(x.err(v, "'volume' must be a <volume> object"));
        }
        let t = self.volume(v)?;
        props.finish(&self.xml, &[])?;
        Ok(t)
    }

    /// The texture a `<volume>` element stands for (memoised per element,
    /// so a volume referenced twice reads its file once).
    pub(crate) fn volume(&mut self, v: Node<'a, 'a>) -> Result<Texture, LoadError> {
        if let Some(t) = self.texture_memo.get(&key(v)) {
            return Ok(*t);
        }
        let x = &self.xml;
        let vp = Props::read(x, v)?;
        let t = match vp.plugin.as_str() {
            "constvolume" => {
                let value = vp.color(x, "value")?.map_or([0.75; 3], |(c, _)| c);
                if value.iter().any(|c| !c.is_finite() || *c < 0.0) {
                    return Err(x.err(v, "constvolume 'value' must be finite and non-negative"));
                }
                // A constant reads the same everywhere: its transform
                // changes nothing.
                vp.finish(x, &["to_world"])?;
                Texture::Constant(Rgb::new(value[0] as f32, value[1] as f32, value[2] as f32))
            }
            "gridvolume" => {
                let id = self.grid_volume(&vp, v)?;
                Texture::Grid(id)
            }
            other => return Err(x.err(v, format!("unsupported volume plugin '{other}'"))),
        };
        self.texture_memo.insert(key(v), t);
        Ok(t)
    }

    /// Reads a `gridvolume` into a pending grid.
    fn grid_volume(&mut self, vp: &Props<'a>, v: Node<'a, 'a>) -> Result<GridId, LoadError> {
        let x = &self.xml;
        let (filename, fnode) = vp
            .string(x, "filename")?
            .ok_or_else(|| x.err(v, "gridvolume lacks the 'filename' property"))?;
        let filter = match vp.string(x, "filter_type")? {
            None => GridFilter::Trilinear,
            Some((f, n)) => match f.as_str() {
                "trilinear" => GridFilter::Trilinear,
                "nearest" => GridFilter::Nearest,
                _ => {
                    return Err(x.err(
                        n,
                        format!("invalid filter_type '{f}' (must be 'trilinear' or 'nearest')"),
                    ));
                }
            },
        };
        let wrap = match vp.string(x, "wrap_mode")? {
            None => GridWrap::Clamp,
            Some((w, n)) => match w.as_str() {
                "clamp" => GridWrap::Clamp,
                "repeat" => GridWrap::Repeat,
                "mirror" => GridWrap::Mirror,
                _ => {
                    return Err(x.err(
                        n,
                        format!("invalid wrap_mode '{w}' (must be 'clamp', 'repeat' or 'mirror')"),
                    ));
                }
            },
        };
        let to_world = vp
            .transform(x, "to_world")?
            .map_or(DMat4::IDENTITY, |(m, _)| m);
        let use_bbox = vp.boolean(x, "use_grid_bbox")?.unwrap_or(false);
        // `raw` only skips spectral upsampling, which an RGB renderer never
        // does; `accel` and `max_value` are lookup aids.
        vp.finish(x, &["raw", "accel", "max_value"])?;
        let path: PathBuf = self.base_dir.join(&filename);
        let file = input::read_bounded(&path, MAX_GRID_BYTES, "volume file")
            .and_then(|bytes| super::vol::decode_vol(&bytes))
            .map_err(|e| x.err(fnode, format!("volume file '{filename}': {e}")))?;
        // World → object (to_world inverted) → unit cube (the file's box
        // stretched onto it when asked).
        let to_object = (transform::is_affine(&to_world) && to_world.determinant().abs() > 0.0)
            .then(|| to_world.inverse())
            .filter(|m| m.is_finite())
            .ok_or_else(|| {
                x.err(
                    v,
                    "gridvolume 'to_world' must be an invertible affine transform",
                )
            })?;
        let to_unit = if use_bbox {
            let (lo, hi) = file.bbox;
            let lo = DVec3::from(lo.map(f64::from));
            let extent = DVec3::from(hi.map(f64::from)) - lo;
            if !(extent.is_finite() && extent.min_element() > 0.0) {
                return Err(x.err(
                    fnode,
                    format!("volume file '{filename}': use_grid_bbox needs a box of positive size"),
                ));
            }
            DMat4::from_scale(extent.recip()) * DMat4::from_translation(-lo)
        } else {
            DMat4::IDENTITY
        };
        let to_local = Affine3A::from_mat4((to_unit * to_object).as_mat4());
        let grid = Grid::new(file.res, file.voxels, to_local, filter, wrap).ok_or_else(|| {
            x.err(
                fnode,
                format!("volume file '{filename}': voxels must be finite and non-negative"),
            )
        })?;
        self.grids.push(Pending::new(grid));
        Ok(GridId(self.grids.len() as u32 - 1))
    }
}
