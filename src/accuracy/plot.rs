//! The ladder's plot, `accuracy.svg`.

use super::*;

/// The log-log plot: error against ns/sample, one labelled point per rung
/// with the Pareto front (left), and the confidence-interval half-width
/// against wall time with its 1/√N line (right). SVG text needs no font
/// files (plotters' SVG backend writes `<text>` elements).
/// Drawn with the run folders' plotting code ([`crate::output::plots`]).
pub fn plot_svg(ladder: &Ladder) -> Result<String, String> {
    crate::output::plots::svg((1400, 640), |root| draw(ladder, root))
}

fn draw(ladder: &Ladder, root: &crate::output::plots::Area) -> Result<(), String> {
    use plotters::prelude::*;
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let (left, right) = root.split_horizontally(860);

    let pts: Vec<&Rung> = ladder
        .rungs
        .iter()
        .filter(|r| r.vs_compliant.v_rms.is_finite() && r.vs_compliant.v_rms > 0.0)
        .collect();
    // Rigid rungs against exact Newton (hollow squares): how far each
    // solver setting is from the LCP it approximates.
    let vs_newton: Vec<&Rung> = ladder
        .rungs
        .iter()
        .filter(|r| {
            r.family != "compliant" && r.vs_newton.v_rms.is_finite() && r.vs_newton.v_rms > 0.0
        })
        .collect();
    // One frictional contact: every rung against `stronge` (hollow
    // triangles), the rigid reference that never creates energy.
    let vs_stronge: Vec<(&Rung, f64)> = ladder
        .rungs
        .iter()
        .filter_map(|r| {
            let e = r.vs_stronge?.v_rms;
            (e.is_finite() && e > 0.0).then_some((r, e))
        })
        .collect();
    let span = |xs: &mut dyn Iterator<Item = f64>| -> (f64, f64) {
        let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
        (lo / 2.0, hi * 2.0)
    };
    // Drop scenes: flight rungs against the finest flight settings.
    let flight: Vec<(&Rung, f64)> = ladder
        .rungs
        .iter()
        .filter_map(|r| {
            let e = r.vs_flight_reference?.v_rms;
            (e.is_finite() && e > 0.0).then_some((r, e))
        })
        .collect();
    let (x0, x1) = span(
        &mut pts
            .iter()
            .chain(vs_newton.iter())
            .map(|r| r.ns_per_sample)
            .chain(flight.iter().map(|(r, _)| r.ns_per_sample))
            .chain(vs_stronge.iter().map(|(r, _)| r.ns_per_sample)),
    );
    let (y0, y1) = span(
        &mut pts
            .iter()
            .map(|r| r.vs_compliant.v_rms)
            .chain(vs_newton.iter().map(|r| r.vs_newton.v_rms))
            .chain(flight.iter().map(|(_, e)| *e))
            .chain(vs_stronge.iter().map(|(_, e)| *e)),
    );
    if !(x0 < x1 && y0 < y1) {
        return Err("nothing to plot: every rung's error is zero or missing".into());
    }
    let mut chart = ChartBuilder::on(&left)
        .caption(
            format!("{}: error vs cost per rung", ladder.scene),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("ns per sample, one thread (log)")
        .y_desc(if vs_stronge.is_empty() {
            "RMS |Δv⁺|, m/s (log): ● vs finest compliant, □ vs exact Newton"
        } else {
            "RMS |Δv⁺|, m/s (log): ● vs finest compliant, □ vs exact Newton, △ vs stronge"
        })
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()
        .map_err(|x| e(&x))?;
    let front: Vec<(f64, f64)> = ladder
        .pareto()
        .iter()
        .map(|r| (r.ns_per_sample, r.vs_compliant.v_rms))
        .collect();
    chart
        .draw_series(LineSeries::new(front, RED.stroke_width(2)))
        .map_err(|x| e(&x))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    // Labels are skipped where one is already close (the table has them all).
    let mut placed: Vec<(f64, f64)> = Vec::new();
    let mut label_for = |r: &Rung, y: f64| -> String {
        let (lx, ly) = (r.ns_per_sample.log10(), y.log10());
        if placed
            .iter()
            .any(|&(px, py)| (px - lx).abs() < 0.25 && (py - ly).abs() < 0.12)
        {
            return String::new();
        }
        placed.push((lx, ly));
        if r.family == "precision" {
            format!("{} {}", r.rung, r.precision)
        } else {
            r.rung.clone()
        }
    };
    for (family, colour) in [("law", BLUE), ("compliant", GREEN), ("precision", MAGENTA)] {
        let sel: Vec<&&Rung> = pts.iter().filter(|r| r.family == family).collect();
        let elems: Vec<_> = sel
            .iter()
            .map(|r| {
                let (x, y) = (r.ns_per_sample, r.vs_compliant.v_rms);
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(label_for(r, y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs compliant"))
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        let sel: Vec<&&Rung> = vs_newton.iter().filter(|r| r.family == family).collect();
        if sel.is_empty() {
            continue;
        }
        let elems: Vec<_> = sel
            .iter()
            .map(|r| {
                let (x, y) = (r.ns_per_sample, r.vs_newton.v_rms);
                EmptyElement::at((x, y))
                    + Rectangle::new([(-4, -4), (4, 4)], colour.stroke_width(1))
                    + Text::new(label_for(r, y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs newton"))
            .legend(move |(x, y)| {
                Rectangle::new([(x + 6, y - 4), (x + 14, y + 4)], colour.stroke_width(1))
            });
    }
    for (family, colour) in [("law", BLUE), ("compliant", GREEN), ("precision", MAGENTA)] {
        let elems: Vec<_> = vs_stronge
            .iter()
            .filter(|(r, _)| r.family == family)
            .map(|(r, y)| {
                EmptyElement::at((r.ns_per_sample, *y))
                    + TriangleMarker::new((0, 0), 5, colour.stroke_width(1))
                    + Text::new(label_for(r, *y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        if elems.is_empty() {
            continue;
        }
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs stronge"))
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, colour.stroke_width(1)));
    }
    for (family, colour) in [("flight_step", CYAN), ("toi_tolerance", BLACK)] {
        let elems: Vec<_> = flight
            .iter()
            .filter(|(r, _)| r.family == family)
            .map(|(r, y)| {
                EmptyElement::at((r.ns_per_sample, *y))
                    + TriangleMarker::new((0, 0), 5, colour.filled())
                    + Text::new(label_for(r, *y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        if elems.is_empty() {
            continue;
        }
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs finest flight"))
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, colour.filled()));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|x| e(&x))?;

    let cs: Vec<&CountRow> = ladder.counts.iter().filter(|c| c.ci95 > 0.0).collect();
    if !cs.is_empty() {
        let (x0, x1) = span(&mut cs.iter().map(|c| c.wall_seconds.max(1e-6)));
        let (y0, y1) = span(&mut cs.iter().map(|c| c.ci95));
        let mut chart = ChartBuilder::on(&right)
            .caption("CI95 half-width vs wall time", ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("wall seconds, all cores (log)")
            .y_desc("95 % CI of mean T⁺/T⁻ (log)")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(|x| e(&x))?;
        // 1/√N through the largest MC N, drawn against the measured walls.
        let mc: Vec<&&CountRow> = cs.iter().filter(|c| c.sampling == "mc").collect();
        if let Some(last) = mc.last() {
            let c = last.ci95 * (last.samples as f64).sqrt();
            chart
                .draw_series(LineSeries::new(
                    mc.iter()
                        .map(|r| (r.wall_seconds.max(1e-6), c / (r.samples as f64).sqrt())),
                    BLACK.stroke_width(1),
                ))
                .map_err(|x| e(&x))?
                .label("MC: σ·1.96/√N")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        }
        for (sampling, colour) in [("mc", BLUE), ("rqmc", RED)] {
            chart
                .draw_series(cs.iter().filter(|r| r.sampling == sampling).map(|r| {
                    EmptyElement::at((r.wall_seconds.max(1e-6), r.ci95))
                        + Circle::new((0, 0), 4, colour.filled())
                        + Text::new(
                            format!("N={:.0e}", r.samples as f64),
                            (6, -12),
                            ("sans-serif", 13),
                        )
                }))
                .map_err(|x| e(&x))?
                .label(sampling)
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(|x| e(&x))?;
    }
    Ok(())
}
