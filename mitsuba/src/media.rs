//! Participating media as Mitsuba 3 writes them: `<medium
//! type="homogeneous">` (σ_t, albedo, scale, a nested `<phase>`), attached
//! to shapes as `interior`/`exterior` and to the sensor; other medium
//! types (Mitsuba's grid-based `heterogeneous`) are refused.

use roxmltree::Node;

use cmlt::math::Rgb;
use cmlt::scene::{Medium, MediumId, MediumInterface, Phase};

use super::error::LoadError;
use super::loader::Loader;
use super::xml::{Item, Props, key};

/// Mitsuba 3's defaults of `homogeneous`.
const DEFAULT_SIGMA_T: f64 = 1.0;
const DEFAULT_ALBEDO: f64 = 0.75;
/// Mitsuba 3's default g of `hg`.
const DEFAULT_HG_G: f64 = 0.8;

fn rgb(c: [f64; 3]) -> Rgb {
    Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

impl<'a> Loader<'a> {
    /// The medium of a `<medium>` element, added to the scene on first use.
    pub(crate) fn use_medium(&mut self, node: Node<'a, 'a>) -> Result<MediumId, LoadError> {
        if let Some(&id) = self.used_media.get(&key(node)) {
            return Ok(id);
        }
        let m = self.medium(node)?;
        let id = self.builder.add_medium(m);
        self.used_media.insert(key(node), id);
        Ok(id)
    }

    fn medium(&self, node: Node<'a, 'a>) -> Result<Medium, LoadError> {
        let x = &self.xml;
        let props = Props::read(x, node)?;
        match props.plugin.as_str() {
            "homogeneous" => {}
            "heterogeneous" => {
                return Err(x.err(
                    node,
                    "heterogeneous (grid) media are not supported: only 'homogeneous'",
                ));
            }
            other => return Err(x.err(node, format!("unsupported medium plugin '{other}'"))),
        }
        let sigma_t = props
            .color(x, "sigma_t")?
            .map_or(Rgb::splat(DEFAULT_SIGMA_T as f32), |(c, _)| rgb(c));
        let albedo = props
            .color(x, "albedo")?
            .map_or(Rgb::splat(DEFAULT_ALBEDO as f32), |(c, _)| rgb(c));
        let scale = props.float(x, "scale")?.map_or(1.0, |(s, _)| s as f32);
        let phases = props.objects("phase");
        let phase = match phases.as_slice() {
            [] => Phase::Isotropic,
            [p] => {
                let Item::Object(n) = p.item else {
                    unreachable!("objects() returns objects")
                };
                self.phase(n)?
            }
            [_, second, ..] => {
                return Err(x.err(second.node, "only one <phase> per medium is allowed"));
            }
        };
        // Both only change which estimator Mitsuba uses, not the image.
        props.finish(x, &["sample_emitters", "has_spectral_extinction"])?;
        Medium::homogeneous(sigma_t, albedo, scale, phase).map_err(|e| x.err(node, e.to_string()))
    }

    fn phase(&self, node: Node<'a, 'a>) -> Result<Phase, LoadError> {
        let x = &self.xml;
        let props = Props::read(x, node)?;
        let phase = match props.plugin.as_str() {
            "isotropic" => Phase::Isotropic,
            "hg" => {
                let (g, at) = props.float(x, "g")?.unwrap_or((DEFAULT_HG_G, node));
                let phase = Phase::HenyeyGreenstein { g: g as f32 };
                phase.validate().map_err(|e| x.err(at, e.to_string()))?;
                phase
            }
            other => return Err(x.err(node, format!("unsupported phase plugin '{other}'"))),
        };
        props.finish(x, &[])?;
        Ok(phase)
    }

    /// A shape's `interior` and `exterior` media (nested or referenced
    /// `<medium>` objects with those names).
    pub(crate) fn shape_media(&mut self, props: &Props<'a>) -> Result<MediumInterface, LoadError> {
        let mut media = MediumInterface::default();
        for e in props.objects("medium") {
            let Item::Object(n) = e.item else {
                unreachable!("objects() returns objects")
            };
            let slot = match e.name.as_deref() {
                Some("interior") => &mut media.interior,
                Some("exterior") => &mut media.exterior,
                other => {
                    let x = &self.xml;
                    return Err(x.err(
                        e.node,
                        format!(
                            "a shape's <medium> must be named 'interior' or 'exterior', found {}",
                            other.map_or("no name".to_string(), |o| format!("'{o}'"))
                        ),
                    ));
                }
            };
            if slot.is_some() {
                return Err(self.xml.err(
                    e.node,
                    "a shape's interior or exterior medium is given twice",
                ));
            }
            *slot = Some(self.use_medium(n)?);
        }
        Ok(media)
    }

    /// The sensor's medium (at most one nested or referenced `<medium>`).
    pub(crate) fn sensor_medium(
        &mut self,
        props: &Props<'a>,
    ) -> Result<Option<MediumId>, LoadError> {
        match props.objects("medium").as_slice() {
            [] => Ok(None),
            [m] => {
                let Item::Object(n) = m.item else {
                    unreachable!("objects() returns objects")
                };
                self.use_medium(n).map(Some)
            }
            [_, second, ..] => Err(self
                .xml
                .err(second.node, "only one <medium> per sensor is allowed")),
        }
    }
}
