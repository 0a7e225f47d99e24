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

/// Margin around the plot and the sizes of the axis label areas, px.
const MARGIN: u32 = 15;
const X_LABEL_AREA: u32 = 50;
const Y_LABEL_AREA: u32 = 80;

/// The axis ranges: the data, padded 5 %, with room for the legend at the top; with
/// `equal_aspect`, the narrower range widened so that a metre is as many pixels along x as
/// along y in a plot area of `plot_pixels` (width, height).
fn ranges(chart: &Chart, plot_pixels: (f64, f64)) -> ((f64, f64), (f64, f64)) {
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
    // Keep the legend clear of the data: extra room at the top.
    y.1 += 0.25 * (y.1 - y.0);
    if chart.equal_aspect {
        (x, y) = equal_scales(x, y, plot_pixels);
    }
    (x, y)
}

/// The ranges `x` and `y`, the narrower widened about its centre so that a unit is as many
/// pixels along x as along y in a plot area of `plot_pixels` (width, height).
fn equal_scales(x: (f64, f64), y: (f64, f64), plot_pixels: (f64, f64)) -> ((f64, f64), (f64, f64)) {
    let (width, height) = (plot_pixels.0.max(1.0), plot_pixels.1.max(1.0));
    let per_pixel = ((x.1 - x.0) / width).max((y.1 - y.0) / height);
    let (cx, cy) = (0.5 * (x.0 + x.1), 0.5 * (y.0 + y.1));
    (
        (cx - 0.5 * width * per_pixel, cx + 0.5 * width * per_pixel),
        (cy - 0.5 * height * per_pixel, cy + 0.5 * height * per_pixel),
    )
}

/// The plot area's size in pixels inside an `area` of `(width, height)`: less the margins and
/// the axis label areas.
fn plot_pixels((width, height): (u32, u32)) -> (f64, f64) {
    (
        f64::from(width.saturating_sub(2 * MARGIN + Y_LABEL_AREA)),
        f64::from(height.saturating_sub(2 * MARGIN + X_LABEL_AREA)),
    )
}

/// Draws `chart`; returns the data units per pixel along x and along y.
fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, chart: &Chart) -> Result<(f64, f64), String>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("error: plotting failed: {e}");
    root.fill(&WHITE).map_err(err)?;
    let area = root.titled(&chart.title, ("sans-serif", 22)).map_err(err)?;
    let ((x0, x1), (y0, y1)) = ranges(chart, plot_pixels(area.dim_in_pixel()));
    let mut ctx = ChartBuilder::on(&area)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    // Data units per pixel along x and y in the plot area as drawn.
    let (plot_width, plot_height) = ctx.plotting_area().dim_in_pixel();
    let scales = ((x1 - x0) / f64::from(plot_width.max(1)), (y1 - y0) / f64::from(plot_height.max(1)));
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
    Ok(scales)
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

/// A quantity over a rectangular grid of a plane, drawn in colour (viridis) with a colour bar.
#[derive(Clone, Debug)]
pub struct Heatmap {
    /// Title.
    pub title: String,
    /// Horizontal axis label (with unit).
    pub x_label: String,
    /// Vertical axis label (with unit).
    pub y_label: String,
    /// The colour bar's label (with unit).
    pub value_label: String,
    /// The cells' centres along x, evenly spaced, increasing.
    pub x: Vec<f64>,
    /// The cells' centres along y, evenly spaced, increasing.
    pub y: Vec<f64>,
    /// The value of cell `(i, j)` at `values[j * x.len() + i]`: `None` where there is no cell
    /// (drawn light grey: outside the workspace), a non-finite value where the quantity is
    /// unbounded (drawn black: a singular pose).
    pub values: Vec<Option<f64>>,
    /// Colours on a logarithmic scale (quantities spanning decades).
    pub log_scale: bool,
    /// A rectangle drawn over the map (lower and upper corners), e.g. a section of the
    /// inscribed cube.
    pub outline: Option<((f64, f64), (f64, f64))>,
}

/// Width of a heatmap's colour bar area, px.
const COLOUR_BAR_AREA: u32 = 150;

/// The colour bar's range: the finite values' least and largest (positive ones on a log scale).
fn colour_range(map: &Heatmap) -> Option<(f64, f64)> {
    let finite =
        map.values.iter().flatten().copied().filter(|v| v.is_finite() && (!map.log_scale || *v > 0.0));
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return None;
    }
    // A constant map still needs a non-empty range.
    let pad = if hi > lo { 0.0 } else { 0.5 * lo.abs().max(1e-12) };
    Some((lo - if map.log_scale { 0.0 } else { pad }, hi + pad))
}

/// Where `v` falls in `range`, 0 to 1.
fn colour_position(v: f64, (lo, hi): (f64, f64), log_scale: bool) -> f64 {
    let t = if log_scale { (v.ln() - lo.ln()) / (hi.ln() - lo.ln()) } else { (v - lo) / (hi - lo) };
    if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

fn draw_heatmap<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, map: &Heatmap) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("error: plotting failed: {e}");
    root.fill(&WHITE).map_err(err)?;
    let area = root.titled(&map.title, ("sans-serif", 20)).map_err(err)?;
    let (width, _) = area.dim_in_pixel();
    let (plot_area, bar_area) = area.split_horizontally(width.saturating_sub(COLOUR_BAR_AREA));
    let half_step = |v: &[f64]| if v.len() > 1 { 0.5 * (v[1] - v[0]) } else { 0.5 };
    let (hx, hy) = (half_step(&map.x), half_step(&map.y));
    let (mut x0, mut x1) =
        (map.x.first().copied().unwrap_or(0.0) - hx, map.x.last().copied().unwrap_or(0.0) + hx);
    let (mut y0, mut y1) =
        (map.y.first().copied().unwrap_or(0.0) - hy, map.y.last().copied().unwrap_or(0.0) + hy);
    // As many pixels per unit along x as along y: a cube's section stays square.
    ((x0, x1), (y0, y1)) = equal_scales((x0, x1), (y0, y1), plot_pixels(plot_area.dim_in_pixel()));
    let mut ctx = ChartBuilder::on(&plot_area)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    ctx.configure_mesh()
        .x_desc(&map.x_label)
        .y_desc(&map.y_label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .disable_mesh()
        .draw()
        .map_err(err)?;
    let range = colour_range(map);
    let nx = map.x.len();
    let cells = map.values.iter().enumerate().map(|(k, value)| {
        let (x, y) = (
            map.x.get(k % nx.max(1)).copied().unwrap_or(0.0),
            map.y.get(k / nx.max(1)).copied().unwrap_or(0.0),
        );
        let colour = match (value, range) {
            (None, _) => RGBColor(225, 225, 225),
            (Some(v), Some(range)) if v.is_finite() && (!map.log_scale || *v > 0.0) => {
                ViridisRGB.get_color(colour_position(*v, range, map.log_scale) as f32)
            }
            (Some(_), _) => BLACK,
        };
        Rectangle::new([(x - hx, y - hy), (x + hx, y + hy)], colour.filled())
    });
    ctx.draw_series(cells).map_err(err)?;
    if let Some(((a, b), (c, d))) = map.outline {
        let red = RGBColor(214, 39, 40);
        ctx.draw_series(std::iter::once(PathElement::new(
            vec![(a, b), (c, b), (c, d), (a, d), (a, b)],
            red.stroke_width(2),
        )))
        .map_err(err)?;
    }
    // The colour bar: the same colours against the value axis.
    if let Some((lo, hi)) = range {
        let strips = 100;
        let mut builder = ChartBuilder::on(&bar_area);
        let bar = builder
            .margin_top(MARGIN)
            .margin_bottom(MARGIN + X_LABEL_AREA)
            .margin_right(5)
            .set_label_area_size(LabelAreaPosition::Left, 95);
        let colours = (0..strips).map(|k| {
            let t = (k as f64 + 0.5) / strips as f64;
            let (a, b) = (k as f64 / strips as f64, (k + 1) as f64 / strips as f64);
            (a, b, ViridisRGB.get_color(t as f32))
        });
        if map.log_scale {
            let mut chart = bar.build_cartesian_2d(0.0..1.0, (lo..hi).log_scale()).map_err(err)?;
            chart
                .configure_mesh()
                .disable_x_axis()
                .disable_mesh()
                .y_desc(&map.value_label)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let at = |t: f64| lo * (hi / lo).powf(t);
            chart
                .draw_series(
                    colours.map(|(a, b, c)| Rectangle::new([(0.0, at(a)), (1.0, at(b))], c.filled())),
                )
                .map_err(err)?;
        } else {
            let mut chart = bar.build_cartesian_2d(0.0..1.0, lo..hi).map_err(err)?;
            chart
                .configure_mesh()
                .disable_x_axis()
                .disable_mesh()
                .y_desc(&map.value_label)
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let at = |t: f64| lo + (hi - lo) * t;
            chart
                .draw_series(
                    colours.map(|(a, b, c)| Rectangle::new([(0.0, at(a)), (1.0, at(b))], c.filled())),
                )
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Size of a heatmap, px.
const HEATMAP_SIZE: (u32, u32) = (760, 600);

/// Writes `map` as `base.svg` and `base.png`.
pub fn save_heatmap(map: &Heatmap, base: &Path) -> Result<(), String> {
    register_font();
    let svg = base.with_extension("svg");
    draw_heatmap(SVGBackend::new(&svg, HEATMAP_SIZE).into_drawing_area(), map)?;
    let png = base.with_extension("png");
    draw_heatmap(BitMapBackend::new(&png, HEATMAP_SIZE).into_drawing_area(), map)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path in the plane is drawn with as many pixels per metre along x as along y: a
    /// circle stays round (it was drawn 25 % flatter while the legend's room was added after
    /// the scales were equalised).
    #[test]
    fn equal_aspect_charts_have_equal_scales() {
        register_font();
        let circle: Vec<(f64, f64)> = (0..=60)
            .map(|i| f64::from(i) * std::f64::consts::TAU / 60.0)
            .map(|a| (0.1 + 0.02 * a.cos(), 0.13 + 0.02 * a.sin()))
            .collect();
        for (wide, tall) in [(1.0, 1.0), (3.0, 1.0), (1.0, 3.0)] {
            let points = circle.iter().map(|&(x, y)| (x * wide, y * tall)).collect();
            let chart = Chart {
                title: "path".into(),
                x_label: "x0 (m)".into(),
                y_label: "x1 (m)".into(),
                series: vec![Series::line("circle", points)],
                equal_aspect: true,
            };
            let mut buffer = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            let root = BitMapBackend::with_buffer(&mut buffer, SIZE).into_drawing_area();
            let (x_per_pixel, y_per_pixel) = draw(root, &chart).expect("drawn");
            let ratio = x_per_pixel / y_per_pixel;
            assert!((ratio - 1.0).abs() < 0.01, "{wide}×{tall}: x scale / y scale = {ratio}");
        }
    }

    /// A heatmap shows its cells in the colour map's colours by value (low: viridis' dark
    /// purple, high: its yellow), a missing cell light grey and an unbounded one black.
    #[test]
    fn heatmap_cells_take_their_values_colours() {
        use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
        register_font();
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let values = (0..100)
            .map(|k| match (k % 10, k / 10) {
                (_, 0) => None,
                (_, 1) => Some(f64::INFINITY),
                (i, _) if i < 5 => Some(1.0),
                _ => Some(2.0),
            })
            .collect();
        let map = Heatmap {
            title: "test".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            value_label: "v".into(),
            x: x.clone(),
            y: x,
            values,
            log_scale: false,
            outline: None,
        };
        let mut buffer = vec![0u8; (HEATMAP_SIZE.0 * HEATMAP_SIZE.1 * 3) as usize];
        draw_heatmap(BitMapBackend::with_buffer(&mut buffer, HEATMAP_SIZE).into_drawing_area(), &map)
            .expect("drawn");
        let count =
            |c: RGBColor| buffer.chunks(3).filter(|p| p[0] == c.0 && p[1] == c.1 && p[2] == c.2).count();
        let (low, high) = (ViridisRGB.get_color(0.0f32), ViridisRGB.get_color(1.0f32));
        // Four rows of five cells each for the low and the high value, one row of each other kind.
        let (l, h, grey, black) = (count(low), count(high), count(RGBColor(225, 225, 225)), count(BLACK));
        assert!(l > 5_000 && h > 5_000, "low {l}, high {h}");
        assert!(grey > 2_000 && black > 2_000, "grey {grey}, black {black}");
        assert!((l as f64 / h as f64 - 1.0).abs() < 0.2, "low {l}, high {h}");
    }
}
