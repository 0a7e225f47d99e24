//! Figures with plotters: every chart is written as SVG and PNG, with a title, labelled axes
//! and a legend. Text is laid out with the DejaVu Sans font embedded in the binary (plotters'
//! `ab_glyph` feature), so no system font or fontconfig is needed.

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

/// The embedded font (DejaVu Sans, Bitstream Vera licence: `assets/DejaVuSans-LICENSE.txt`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

static FONT_REGISTRATION: Once = Once::new();

fn register_font() {
    FONT_REGISTRATION.call_once(|| {
        // The font is a valid TrueType file shipped with the crate; if registration ever
        // failed, text would be missing but the plot would still be written.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesKind {
    /// A solid line.
    Line,
    /// A dashed line (constraints, predictions).
    Dashed,
    /// A line with a marker every few samples (the paper's "marked line").
    Marked,
}

/// One data series.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points `(x, y)`.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub kind: SeriesKind,
}

impl Series {
    /// A solid line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series { name: name.into(), points, kind: SeriesKind::Line }
    }
    /// A dashed line.
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series { name: name.into(), points, kind: SeriesKind::Dashed }
    }
    /// A marked line.
    pub fn marked(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series { name: name.into(), points, kind: SeriesKind::Marked }
    }
}

/// A chart: title, axis labels, series.
#[derive(Clone, Debug)]
pub struct Chart {
    /// Title.
    pub title: String,
    /// Horizontal axis label (with unit).
    pub x_label: String,
    /// Vertical axis label (with unit).
    pub y_label: String,
    /// The data.
    pub series: Vec<Series>,
    /// Same scale on both axes (paths in the plane).
    pub equal_aspect: bool,
}

const SIZE: (u32, u32) = (900, 600);

fn color(index: usize) -> RGBColor {
    const COLORS: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(23, 190, 207),
        RGBColor(140, 86, 75),
        RGBColor(0, 0, 0),
    ];
    COLORS[index % COLORS.len()]
}

fn ranges(chart: &Chart) -> ((f64, f64), (f64, f64)) {
    let mut x = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y = (f64::INFINITY, f64::NEG_INFINITY);
    for (px, py) in chart.series.iter().flat_map(|s| s.points.iter()) {
        if px.is_finite() && py.is_finite() {
            x = (x.0.min(*px), x.1.max(*px));
            y = (y.0.min(*py), y.1.max(*py));
        }
    }
    let pad = |r: (f64, f64)| {
        if !r.0.is_finite() {
            return (0.0, 1.0);
        }
        let span = (r.1 - r.0).max(1e-9 * r.0.abs().max(1.0)).max(1e-12);
        (r.0 - 0.05 * span, r.1 + 0.05 * span)
    };
    let (mut x, mut y) = (pad(x), pad(y));
    if chart.equal_aspect {
        // Plot area is roughly 780 × 480 px: widen the narrower range.
        let per_pixel = ((x.1 - x.0) / 780.0).max((y.1 - y.0) / 480.0);
        let (cx, cy) = (0.5 * (x.0 + x.1), 0.5 * (y.0 + y.1));
        x = (cx - 390.0 * per_pixel, cx + 390.0 * per_pixel);
        y = (cy - 240.0 * per_pixel, cy + 240.0 * per_pixel);
    }
    // Keep the legend clear of the data: extra room at the top.
    let span = y.1 - y.0;
    (x, (y.0, y.1 + 0.25 * span))
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, chart: &Chart) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("error: plotting failed: {e}");
    root.fill(&WHITE).map_err(err)?;
    let ((x0, x1), (y0, y1)) = ranges(chart);
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    for (i, series) in chart.series.iter().enumerate() {
        let c = color(i);
        let style = ShapeStyle::from(&c).stroke_width(2);
        let points: Vec<(f64, f64)> =
            series.points.iter().copied().filter(|(a, b)| a.is_finite() && b.is_finite()).collect();
        let annotation = match series.kind {
            SeriesKind::Line => ctx.draw_series(LineSeries::new(points, style)).map_err(err)?,
            SeriesKind::Dashed => ctx.draw_series(DashedLineSeries::new(points, 8, 5, style)).map_err(err)?,
            SeriesKind::Marked => {
                let every = (points.len() / 60).max(1);
                let markers: Vec<(f64, f64)> = points.iter().copied().step_by(every).collect();
                ctx.draw_series(markers.into_iter().map(|p| Circle::new(p, 3, c.stroke_width(1))))
                    .map_err(err)?;
                ctx.draw_series(LineSeries::new(points, c.stroke_width(1))).map_err(err)?
            }
        };
        let kind = series.kind;
        annotation.label(&series.name).legend(move |(x, y)| {
            let line = PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2));
            let marker = Circle::new((x + 12, y), if kind == SeriesKind::Marked { 3 } else { 0 }, c.filled());
            EmptyElement::at((0, 0)) + line + marker
        });
    }
    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Writes `chart` as `base.svg` and `base.png`.
pub fn save(chart: &Chart, base: &Path) -> Result<(), String> {
    register_font();
    let svg = base.with_extension("svg");
    draw(SVGBackend::new(&svg, SIZE).into_drawing_area(), chart)?;
    let png = base.with_extension("png");
    draw(BitMapBackend::new(&png, SIZE).into_drawing_area(), chart)?;
    Ok(())
}
