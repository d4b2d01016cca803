//! Participating media in the Mitsuba 3 XML loader: `homogeneous` media
//! with their phase functions, attached to shapes (`interior`,
//! `exterior`) and to the sensor, the `null` BSDF; and each malformed case
//! refused with its line.

use std::path::Path;

use cmlt::math::Rgb;
use cmlt::scene::{MaterialKind, Medium, MediumId, MediumInterface, Phase};
use cmlt_cli::mitsuba::{LoadError, LoadedScene, load_scene_str};

/// A scene whose sensor holds `sensor_extra`, then `body` from line 6 on.
fn load(sensor_extra: &str, body: &str) -> Result<LoadedScene, LoadError> {
    let xml = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">{sensor_extra}
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
{body}
</scene>"#
    );
    load_scene_str(&xml, Path::new("."), "inline.xml", &[])
}

#[test]
fn homogeneous_media_load_as_mitsuba_3_writes_them() {
    let s = load(
        r#"<ref id="haze"/>"#,
        r#"<medium type="homogeneous" id="haze">
        <rgb name="sigma_t" value="0.1, 0.2, 0.4"/>
        <float name="albedo" value="0.9"/>
        <float name="scale" value="2"/>
        <phase type="hg"><float name="g" value="0.3"/></phase>
    </medium>
    <shape type="sphere">
        <bsdf type="dielectric"/>
        <medium type="homogeneous" name="interior">
            <spectrum name="sigma_t" value="1.5"/>
        </medium>
        <ref name="exterior" id="haze"/>
    </shape>
    <shape type="cube"><bsdf type="null"/><ref name="interior" id="haze"/></shape>
    <shape type="cube"><bsdf type="diffuse"/></shape>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .scene;
    let haze = Medium::homogeneous(
        Rgb::new(0.1, 0.2, 0.4),
        Rgb::splat(0.9),
        2.0,
        Phase::HenyeyGreenstein { g: 0.3 },
    )
    .unwrap();
    // Mitsuba 3's defaults: albedo 0.75, isotropic phase.
    let inner =
        Medium::homogeneous(Rgb::splat(1.5), Rgb::splat(0.75), 1.0, Phase::Isotropic).unwrap();
    assert_eq!(s.media, vec![haze, inner]);
    assert_eq!(s.camera_medium(), Some(MediumId(0)));
    // Meshes: the emitter, the sphere, the null cube, the diffuse cube.
    assert_eq!(s.surface_media(0), MediumInterface::default());
    assert_eq!(
        s.surface_media(1),
        MediumInterface {
            interior: Some(MediumId(1)),
            exterior: Some(MediumId(0)),
        }
    );
    assert_eq!(
        s.surface_media(2),
        MediumInterface {
            interior: Some(MediumId(0)),
            exterior: None,
        }
    );
    assert_eq!(s.surface_media(3), MediumInterface::default());
    let null = s.meshes[2].material;
    assert_eq!(s.materials[null.0 as usize].kind, MaterialKind::Null);
    assert!(s.has_media());
    // A scene without media has none of it.
    let plain = load("", "").unwrap().scene;
    assert!(!plain.has_media() && plain.media.is_empty());
}

#[test]
fn malformed_media_are_refused_at_their_line() {
    for (sensor, body, line, phrase) in [
        (
            "",
            r#"<medium type="heterogeneous"/>"#,
            6,
            "heterogeneous (grid) media are not supported",
        ),
        (
            "",
            r#"<medium type="fancy"/>"#,
            6,
            "unsupported medium plugin 'fancy'",
        ),
        (
            "",
            r#"<medium type="homogeneous"><rgb name="sigma_t" value="1, -1, 1"/></medium>"#,
            6,
            "sigma_t",
        ),
        (
            "",
            r#"<medium type="homogeneous"><float name="scale" value="inf"/></medium>"#,
            6,
            "not a finite number",
        ),
        (
            "",
            r#"<medium type="homogeneous"><rgb name="albedo" value="0.5, 1.2, 0.5"/></medium>"#,
            6,
            "albedo must be in [0, 1]",
        ),
        (
            "",
            "<medium type=\"homogeneous\">\n<phase type=\"hg\"><float name=\"g\" value=\"1\"/></phase></medium>",
            7,
            "|g| < 1",
        ),
        (
            "",
            "<medium type=\"homogeneous\">\n<phase type=\"rayleigh\"/></medium>",
            7,
            "unsupported phase plugin 'rayleigh'",
        ),
        (
            "",
            "<medium type=\"homogeneous\"><phase type=\"isotropic\"/>\n<phase type=\"isotropic\"/></medium>",
            7,
            "only one <phase> per medium",
        ),
        (
            "",
            r#"<medium type="homogeneous"><float name="density" value="1"/></medium>"#,
            6,
            "unsupported property 'density'",
        ),
        (
            "",
            r#"<phase type="isotropic"/>"#,
            6,
            "must be nested inside a <medium>",
        ),
        (
            "",
            r#"<volume type="gridvolume"/>"#,
            6,
            "gridvolume lacks the 'filename' property",
        ),
        (
            "",
            "<medium type=\"homogeneous\" id=\"m\"/>\n<shape type=\"cube\"><ref name=\"inside\" id=\"m\"/></shape>",
            7,
            "must be named 'interior' or 'exterior', found 'inside'",
        ),
        (
            "",
            "<medium type=\"homogeneous\" id=\"m\"/>\n<shape type=\"cube\"><ref name=\"interior\" id=\"m\"/>\n<ref name=\"interior\" id=\"m\"/></shape>",
            8,
            "given twice",
        ),
        (
            r#"<medium type="homogeneous"/><medium type="homogeneous"/>"#,
            "",
            2,
            "only one <medium> per sensor",
        ),
        (
            "",
            r#"<shape type="cube"><ref name="interior" id="nowhere"/></shape>"#,
            6,
            "nowhere",
        ),
    ] {
        let e = load(sensor, body)
            .err()
            .unwrap_or_else(|| panic!("accepted: {sensor} {body}"));
        let text = e.to_string();
        assert!(text.contains(phrase), "{body}: {text}");
        assert!(
            text.starts_with(&format!("inline.xml:{line}:")),
            "{body}: {text}"
        );
    }
}
