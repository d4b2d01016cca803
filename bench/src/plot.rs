//! Plots of the accuracy benchmarks, each written as `PREFIX.png` and
//! `PREFIX.svg` with plotters.
//!
//! Text is drawn with a font compiled into the binary (DejaVu Sans, cut
//! down to ASCII and a few symbols; `bench/assets/fonts/`) through plotters'
//! `ab_glyph` feature, so plotting needs no system fonts or fontconfig.
//! PNGs are encoded with the `image` crate the CLI already uses.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::convergence::Curve;

/// The embedded font (Bitstream Vera licence, see `bench/assets/fonts/`).
const FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans-subset.ttf");

/// Registers [`FONT`] as plotters' `sans-serif` (every style falls back to
/// it), once per process.
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_err() {
            // The font is compiled in; failing to parse it is a build bug.
            panic!("the embedded plot font does not parse");
        }
    });
}

/// Line colours, one per method (Tableau 10, distinguishable in print).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// `prefix` with `.ext` appended (not replacing: prefixes may contain dots).
fn with_ext(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A generic drawing function usable with both backends.
macro_rules! both_backends {
    ($f:ident ( $($arg:expr),* )) => {
        Both(
            |root: &DrawingArea<BitMapBackend<'_>, Shift>| $f(root, $($arg),*),
            |root: &DrawingArea<SVGBackend<'_>, Shift>| $f(root, $($arg),*),
        )
    };
}

/// A pair of drawing closures, one per backend (closures cannot be generic
/// over the backend type, so the same generic function is wrapped twice).
struct Both<A, B>(A, B);

fn write_both<A, B>(
    prefix: &Path,
    size: (u32, u32),
    both: Both<A, B>,
) -> Result<Vec<PathBuf>, String>
where
    A: Fn(&DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult,
    B: Fn(&DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult,
{
    register_font();
    let png = with_ext(prefix, "png");
    let svg = with_ext(prefix, "svg");
    let mut buf = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        (both.0)(&root).map_err(|e| format!("{}: {e}", png.display()))?;
        root.present()
            .map_err(|e| format!("{}: {e}", png.display()))?;
    }
    image::save_buffer(&png, &buf, size.0, size.1, image::ColorType::Rgb8)
        .map_err(|e| format!("{}: {e}", png.display()))?;
    {
        let root = SVGBackend::new(&svg, size).into_drawing_area();
        (both.1)(&root).map_err(|e| format!("{}: {e}", svg.display()))?;
        root.present()
            .map_err(|e| format!("{}: {e}", svg.display()))?;
    }
    Ok(vec![png, svg])
}

/// Log–log plot of relMSE against wall-clock time, one line per curve,
/// written to `PREFIX.png` and `PREFIX.svg`; returns the two paths.
pub fn convergence(curves: &[Curve], title: &str, prefix: &Path) -> Result<Vec<PathBuf>, String> {
    let pts = curves.iter().flat_map(|c| &c.points);
    let (mut t0, mut t1, mut e0, mut e1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in pts.filter(|p| p.wall_s > 0.0 && p.rel_mse > 0.0) {
        t0 = t0.min(p.wall_s);
        t1 = t1.max(p.wall_s);
        e0 = e0.min(p.rel_mse);
        e1 = e1.max(p.rel_mse);
    }
    if t0 > t1 {
        return Err("nothing to plot: no points with positive time and error".to_string());
    }
    // Pad the ranges by a fraction of a decade so end points are not on the frame.
    let range = ((t0 / 1.3)..(t1 * 1.3), (e0 / 1.5)..(e1 * 1.5));
    write_both(
        prefix,
        (960, 640),
        both_backends!(draw_convergence(curves, title, &range)),
    )
}

fn draw_convergence<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    curves: &[Curve],
    title: &str,
    range: &(std::ops::Range<f64>, std::ops::Range<f64>),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(range.0.clone().log_scale(), range.1.clone().log_scale())?;
    chart
        .configure_mesh()
        .x_desc("wall-clock time (s)")
        .y_desc("relative MSE")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .x_label_formatter(&|v| tidy(*v))
        .y_label_formatter(&|v| tidy(*v))
        .draw()?;
    for (i, c) in curves.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let pts: Vec<(f64, f64)> = c
            .points
            .iter()
            .filter(|p| p.wall_s > 0.0 && p.rel_mse > 0.0)
            .map(|p| (p.wall_s, p.rel_mse))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(c.method.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2))
            });
        chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// An axis label: up to three significant digits, no exponent (log axes
/// put labels at 1, 2, 5 × powers of ten).
fn tidy(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let decimals = (2.0 - v.log10().floor()).clamp(0.0, 12.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// One panel of a heat map: values over an x × y grid.
#[derive(Clone, Debug)]
pub struct HeatPanel {
    /// Panel title.
    pub title: String,
    /// Column labels (x axis).
    pub x_labels: Vec<String>,
    /// Row labels (y axis, bottom to top).
    pub y_labels: Vec<String>,
    /// `values[y][x]`; NaN = not measured.
    pub values: Vec<Vec<f64>>,
    /// A cell to outline (the best), as (x, y).
    pub mark: Option<(usize, usize)>,
}

/// Heat maps side by side on one shared logarithmic colour scale (low =
/// dark), each cell labelled with its value; written to `PREFIX.png` and
/// `PREFIX.svg`.
pub fn heat_maps(
    panels: &[HeatPanel],
    title: &str,
    x_desc: &str,
    y_desc: &str,
    prefix: &Path,
) -> Result<Vec<PathBuf>, String> {
    if panels.is_empty() {
        return Err("nothing to plot".to_string());
    }
    let finite = panels
        .iter()
        .flat_map(|p| p.values.iter().flatten())
        .filter(|v| v.is_finite() && **v > 0.0);
    let (lo, hi) = finite.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    let scale = (lo.ln(), hi.ln().max(lo.ln() + 1e-9));
    let width = (80 + 420 * panels.len() as u32).max(720);
    write_both(
        prefix,
        (width, 520),
        both_backends!(draw_heat_maps(panels, title, x_desc, y_desc, scale)),
    )
}

/// A dark-to-light colour ramp (viridis' end points and middle), t in [0, 1].
fn ramp(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |u: f64, v: f64| (u + f * (v - u)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

fn draw_heat_maps<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[HeatPanel],
    title: &str,
    x_desc: &str,
    y_desc: &str,
    scale: (f64, f64),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let areas = root.split_evenly((1, panels.len()));
    for (panel, area) in panels.iter().zip(&areas) {
        let (nx, ny) = (panel.x_labels.len(), panel.y_labels.len());
        // Cell (i, j) spans [i − ½, i + ½] × [j − ½, j + ½], so the axes'
        // integer key points fall on cell centres and carry the labels.
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d(-0.5..nx as f64 - 0.5, -0.5..ny as f64 - 0.5)?;
        let label = |labels: &[String], v: f64| {
            let i = v.round();
            if (v - i).abs() < 1e-6 && i >= 0.0 {
                labels.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_labels(nx)
            .y_labels(ny)
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 16))
            .x_label_formatter(&|v| label(&panel.x_labels, *v))
            .y_label_formatter(&|v| label(&panel.y_labels, *v))
            .draw()?;
        let cell = |x: usize, y: usize| {
            let (x, y) = (x as f64, y as f64);
            [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)]
        };
        for (y, row) in panel.values.iter().enumerate() {
            for (x, &v) in row.iter().enumerate() {
                let t = if v.is_finite() && v > 0.0 {
                    (v.ln() - scale.0) / (scale.1 - scale.0)
                } else {
                    f64::NAN
                };
                let fill = if t.is_nan() {
                    RGBColor(220, 220, 220)
                } else {
                    ramp(t)
                };
                chart.draw_series(std::iter::once(Rectangle::new(cell(x, y), fill.filled())))?;
                let text = if v.is_finite() {
                    format!("{v:.4}")
                } else {
                    "–".to_string()
                };
                let ink = if t < 0.6 { WHITE } else { BLACK };
                let style = ("sans-serif", 14)
                    .into_font()
                    .color(&ink)
                    .pos(Pos::new(HPos::Center, VPos::Center));
                chart.draw_series(std::iter::once(Text::new(
                    text,
                    (x as f64, y as f64),
                    style,
                )))?;
            }
        }
        if let Some((x, y)) = panel.mark {
            chart.draw_series(std::iter::once(Rectangle::new(
                cell(x, y),
                RGBColor(220, 20, 60).stroke_width(4),
            )))?;
        }
    }
    Ok(())
}
