//! SVG plots, for a run folder's `plots/` and for the accuracy ladder: the
//! plotters SVG backend (text as `<text>` elements, so no font files are
//! needed) behind a few chart shapes, and the run's own figures drawn with
//! them.
//!
//! A run draws, per sweep point, from its accumulators:
//! - `energy_ratio.svg`: the energy ratio's distribution under every law,
//!   overlaid (densities from the quantile histograms);
//! - `active_sets.svg`: the fraction of samples by the set of planes that
//!   took an impulse, per law (first impacts in a drop scene);
//! - `sequences.svg` (drop scenes): the most frequent sequences of planes
//!   hit over the first impacts, per law.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::config::Scene;
use crate::output::summary::{active_set_name, sequence_name};
use crate::stats::accumulators::RunAcc;
use crate::stats::LogHistogram;

/// A drawing area of the SVG backend.
pub type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// A plotters error as text.
pub fn err(x: impl std::fmt::Display) -> String {
    x.to_string()
}

/// An SVG of `size` pixels drawn by `draw` on a white background.
pub fn svg(
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), String>,
) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(out)
}

/// The colour of series `i` (a law, in scene order).
pub fn colour(i: usize) -> RGBColor {
    const C: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(23, 190, 207),
    ];
    C[i % C.len()]
}

/// Named lines over a shared x axis, linear scales.
pub fn lines(
    title: &str,
    (x_desc, y_desc): (&str, &str),
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<String, String> {
    let pts = || series.iter().flat_map(|(_, p)| p.iter());
    let (x0, x1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let y1 = pts().fold(0.0f64, |m, p| m.max(p.1));
    if !(x0 < x1 && y1 > 0.0) {
        return Err(format!("{title}: nothing to plot"));
    }
    svg((900, 560), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, 0.0..y1 * 1.05)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        for (i, (name, p)) in series.iter().enumerate() {
            let c = colour(i);
            chart
                .draw_series(LineSeries::new(p.iter().copied(), c.stroke_width(2)))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(err)
    })
}

/// Grouped horizontal bars: one group per category (top to bottom), one
/// bar per series, values in [0, 1] (fractions).
pub fn grouped_bars(
    title: &str,
    x_desc: &str,
    categories: &[String],
    series: &[(String, Vec<f64>)],
) -> Result<String, String> {
    let top = series
        .iter()
        .flat_map(|(_, v)| v.iter())
        .fold(0.0f64, |m, &x| m.max(x));
    if categories.is_empty() || !(top > 0.0) {
        return Err(format!("{title}: nothing to plot"));
    }
    let n = categories.len();
    let k = series.len().max(1) as f64;
    let height = (140 + 22 * n as u32 * series.len().max(1) as u32).clamp(360, 1600);
    let label_width = categories
        .iter()
        .map(|c| c.chars().count())
        .max()
        .unwrap_or(4) as u32
        * 8
        + 20;
    svg((1000, height), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(label_width.clamp(60, 420))
            .build_cartesian_2d(0.0..(top * 1.25).min(1.0), 0.0..n as f64)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(2 * n + 1)
            .y_label_formatter(&|y| {
                // A label at each group's centre only, the first group on top.
                let c = y - 0.5;
                if c >= 0.0 && (c - c.round()).abs() < 1e-9 {
                    let g = c.round() as usize;
                    n.checked_sub(g + 1)
                        .map(|i| categories[i].clone())
                        .unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .x_desc(x_desc)
            .draw()
            .map_err(err)?;
        for (i, (name, values)) in series.iter().enumerate() {
            let c = colour(i);
            chart
                .draw_series(values.iter().enumerate().map(|(g, &v)| {
                    let y = (n - 1 - g) as f64 + 0.9 - 0.8 * (i as f64 + 1.0) / k;
                    Rectangle::new([(0.0, y), (v, y + 0.8 / k)], c.filled())
                }))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(err)
    })
}

/// A histogram's density on `bins` equal intervals over `[lo, hi]`: each
/// log-linear bin's count is spread uniformly over its own width and
/// shared among the intervals it overlaps (no aliasing between the two bin
/// grids); exact zeros go to the first interval.
fn density(h: &LogHistogram, (lo, hi): (f64, f64), bins: usize) -> Vec<(f64, f64)> {
    let n = h.total() as f64;
    let w = (hi - lo) / bins as f64;
    let mut mass = vec![0.0f64; bins];
    let at = |x: f64| (((x - lo) / w).floor().max(0.0) as usize).min(bins - 1);
    for (a, b, c) in h.bins() {
        let c = c as f64;
        if !(b > a) {
            mass[at(a)] += c;
            continue;
        }
        for (k, m) in mass.iter_mut().enumerate().take(at(b) + 1).skip(at(a)) {
            let (x0, x1) = (lo + k as f64 * w, lo + (k + 1) as f64 * w);
            let overlap = (b.min(x1) - a.max(x0)).max(0.0);
            *m += c * overlap / (b - a);
        }
    }
    mass.iter()
        .enumerate()
        .map(|(k, &m)| (lo + (k as f64 + 0.5) * w, m / (n * w)))
        .collect()
}

/// The figures of one run (one sweep point) as `(file name, SVG)`, names
/// suffixed by `suffix` (`-point3` in a sweep). A figure whose data the
/// run did not keep (the energy ratio without quantiles), or that has
/// nothing to show (a shard that ran no batch), is left out.
pub fn run_plots(
    scene: &Scene,
    planes: &[String],
    acc: &RunAcc,
    suffix: &str,
) -> Result<Vec<(String, String)>, String> {
    let laws: Vec<String> = scene.laws().iter().map(|l| l.name()).collect();
    let title = |what: &str| format!("{}: {what}", scene.name());
    let mut out = Vec::new();

    let kept: Vec<(usize, &LogHistogram)> = acc
        .laws
        .iter()
        .enumerate()
        .map(|(i, a)| (i, &a.energy_ratio.hist))
        .filter(|(_, h)| h.total() > 0)
        .collect();
    if !kept.is_empty() {
        let hi = kept
            .iter()
            .map(|&(i, _)| acc.laws[i].energy_ratio.moments.max())
            .fold(1.0f64, f64::max);
        let series: Vec<(String, Vec<(f64, f64)>)> = kept
            .iter()
            .map(|&(i, h)| (laws[i].to_string(), density(h, (0.0, hi), 100)))
            .collect();
        out.push((
            format!("energy_ratio{suffix}.svg"),
            lines(
                &title("energy ratio T⁺/T⁻ of impacting samples"),
                ("T⁺/T⁻", "density"),
                &series,
            )?,
        ));
    }

    let masks: Vec<usize> = (0..1usize << planes.len())
        .filter(|&m| acc.laws.iter().any(|a| a.active_sets[m] > 0))
        .collect();
    let name = |m: usize| active_set_name(m, planes);
    let series: Vec<(String, Vec<f64>)> = acc
        .laws
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let n = a.samples.max(1) as f64;
            let v = masks.iter().map(|&m| a.active_sets[m] as f64 / n).collect();
            (laws[i].to_string(), v)
        })
        .collect();
    let drawn = series.iter().any(|(_, v)| v.iter().any(|&x| x > 0.0));
    let what = if acc.drops.is_empty() {
        "planes that took an impulse"
    } else {
        "planes that took an impulse at the first impact"
    };
    if drawn {
        out.push((
            format!("active_sets{suffix}.svg"),
            grouped_bars(
                &title(what),
                "fraction of samples",
                &masks.iter().map(|&m| name(m)).collect::<Vec<_>>(),
                &series,
            )?,
        ));
    }

    if let Some(first) = acc
        .drops
        .first()
        .filter(|d| d.sequences.iter().any(|&c| c > 0))
    {
        // The most frequent sequences under the first law, at most twelve.
        let mut cells = first.sequences_by_frequency();
        cells.truncate(12);
        let categories: Vec<String> = cells
            .iter()
            .map(|&(c, _)| sequence_name(&first.sequence_masks(c), planes))
            .collect();
        let series: Vec<(String, Vec<f64>)> = acc
            .drops
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let n = d.samples.max(1) as f64;
                let v = cells
                    .iter()
                    .map(|&(c, _)| d.sequences[c] as f64 / n)
                    .collect();
                (laws[i].to_string(), v)
            })
            .collect();
        out.push((
            format!("sequences{suffix}.svg"),
            grouped_bars(
                &title(&format!(
                    "planes hit over the first {} impacts",
                    first.sequence_impacts()
                )),
                "fraction of samples",
                &categories,
                &series,
            )?,
        ));
    }
    Ok(out)
}
