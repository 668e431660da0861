//! One log-log plot per scene: relMSE against render time, one curve per configuration, as SVG
//! (plotters' SVG backend writes text as `<text>` elements, so no fonts are needed).
//!
//! Colour: the estimator. Solid: Sobol; dashed: independent. Thick: Russian roulette on; thin
//! and pale: off. Grey dashes: the reference's noise floor (an upper bound of it).
use super::SceneResult;
use super::measure::{Config, Point};
use plotters::prelude::*;
use tessera_render::tracer::Estimator;
use tessera_render::tracer::sampler::SamplerKind;

const SIZE: (u32, u32) = (860, 600);
/// relMSE values below this are drawn at it (an exact estimator would otherwise stretch the axis).
const LOWEST: f64 = 1e-9;

fn colour(e: Estimator) -> RGBColor {
    match e {
        Estimator::Mis => RGBColor(31, 90, 200),
        Estimator::Light => RGBColor(30, 150, 60),
        Estimator::Bsdf => RGBColor(230, 130, 0),
        Estimator::Naive => RGBColor(200, 30, 30),
    }
}

fn style(c: &Config) -> ShapeStyle {
    let base = colour(c.estimator);
    if c.roulette { base.stroke_width(2) } else { base.mix(0.45).stroke_width(1) }
}

pub fn svg(scene: &SceneResult) -> anyhow::Result<String> {
    let pts = |p: &[Point]| -> Vec<(f64, f64)> {
        p.iter().map(|p| (p.time_s.max(1e-6), p.rel_mse.max(LOWEST))).collect()
    };
    let all: Vec<(f64, f64)> = scene.curves.iter().flat_map(|(_, p)| pts(p)).collect();
    anyhow::ensure!(!all.is_empty(), "no points to plot for {}", scene.name);
    let (x0, x1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (mut y0, y1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if scene.reference_floor > 0.0 {
        y0 = y0.min(scene.reference_floor);
    }
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{}: relMSE vs render time", scene.name), ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d((x0 / 1.5..x1 * 1.5).log_scale(), (y0 / 2.0..y1 * 2.0).log_scale())
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("render time (s), 2 cores")
            .y_desc("relMSE")
            .x_label_formatter(&|v| format!("{v:.2e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(plot_err)?;
        for (config, points) in &scene.curves {
            let (p, s) = (pts(points), style(config));
            let series = match config.sampler {
                SamplerKind::Sobol => chart.draw_series(LineSeries::new(p, s)),
                SamplerKind::Independent => chart.draw_series(DashedLineSeries::new(p, 6, 4, s)),
            };
            series
                .map_err(plot_err)?
                .label(config.label())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], s));
        }
        if scene.reference_floor > 0.0 {
            let grey = RGBColor(120, 120, 120).stroke_width(1);
            let floor = [(x0 / 1.5, scene.reference_floor), (x1 * 1.5, scene.reference_floor)];
            chart
                .draw_series(DashedLineSeries::new(floor, 3, 5, grey))
                .map_err(plot_err)?
                .label("reference noise floor (≤)")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], grey));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(out)
}

fn plot_err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plotting failed: {e:?}")
}
