//! One entry point per stage of the tracker, for the criterion benches
//! (`benches/template.rs`): each runs the crate-private code on inputs the bench makes.

use super::filter::CorrelationFilter;
use super::hog::{self, CHANNELS, FeatureMap};
use super::likelihood::{ColourLikelihood, Rect, colour_response, integral};
use super::patch::{self, Patch, Window};
use super::scale::ScaleFilter;
use super::sharpness::{average_peak_correlation_energy, peak_to_sidelobe};
use crate::colour::ColorSpace;
use crate::frame::RgbFrame;

/// Resamples a `width x height` window centred in `frame` to the same size; returns
/// the patch's mean grey level (so the work cannot be optimised away).
pub fn resample(frame: RgbFrame<'_>, width: usize, height: usize) -> f32 {
    let window = Window {
        cx: frame.width() as f64 / 2.0,
        cy: frame.height() as f64 / 2.0,
        width: width as f64 * 1.3,
        height: height as f64 * 1.3,
    };
    let mut out = Patch::default();
    patch::sample(&frame, window, width, height, &mut out);
    out.grey.iter().sum::<f32>() / out.grey.len() as f32
}

/// HOG + intensity features of a grey image with 4-pixel cells; returns a checksum.
pub fn hog_features(grey: &[f32], width: usize, height: usize) -> f32 {
    let mut map = FeatureMap::default();
    hog::features(grey, width, height, 4, &mut map);
    map.planes.iter().flatten().sum()
}

/// A translation filter over a `width x height` grid of cells, trained on a
/// deterministic pattern.
pub struct Translation {
    filter: CorrelationFilter,
    map: FeatureMap,
    response: Vec<f32>,
}

impl Translation {
    /// A trained filter.
    pub fn new(width: usize, height: usize) -> Self {
        let map = FeatureMap {
            width,
            height,
            planes: (0..CHANNELS)
                .map(|c| {
                    (0..width * height)
                        .map(|k| ((k * 7 + c * 13) % 17) as f32 / 17.0)
                        .collect()
                })
                .collect(),
        };
        let mut filter = CorrelationFilter::new(width, height, 1.5, 1e-3);
        filter.train(&map, 1.0);
        Self {
            filter,
            map,
            response: Vec::new(),
        }
    }

    /// One response map (detection) and one training step (learning).
    pub fn respond_and_train(&mut self) -> f32 {
        self.filter.respond(&self.map, &mut self.response);
        self.filter.train(&self.map, 0.01);
        self.response[0]
    }
}

/// A scale filter over `n` scales of `dims`-long features.
pub struct Scale {
    filter: ScaleFilter,
    samples: Vec<Vec<f32>>,
}

impl Scale {
    /// A trained filter.
    pub fn new(n: usize, dims: usize) -> Self {
        let samples: Vec<Vec<f32>> = (0..n)
            .map(|k| {
                (0..dims)
                    .map(|d| ((k * 5 + d * 3) % 11) as f32 / 11.0)
                    .collect()
            })
            .collect();
        let mut filter = ScaleFilter::new(n, 1.0, 1e-3);
        filter.train(&samples, 1.0);
        Self { filter, samples }
    }

    /// One response over the scales.
    pub fn respond(&mut self) -> f32 {
        self.filter.respond(&self.samples)[0]
    }
}

/// Learns colour histograms on a `width x height` RGB patch (32 bins per axis), then
/// back-projects it and computes the colour response on a grid of 4-pixel cells.
pub fn colour(rgb: &[[u8; 3]], width: usize, height: usize) -> f32 {
    let mut model = ColourLikelihood::new(ColorSpace::Rgb, [32, 32, 32]);
    let target = Rect::centred(width, height, width as f64 / 2.0, height as f64 / 2.0);
    let object = Rect::centred(width, height, width as f64 / 3.0, height as f64 / 3.0);
    model.learn(rgb, width, target, object, 1.0);
    let mut p = Vec::new();
    model.back_project(rgb, &mut p);
    let table = integral(&p, width, height);
    let mut out = Vec::new();
    let size = (width as f64 / 2.0, height as f64 / 2.0);
    colour_response(
        &table,
        width,
        height,
        size,
        (width / 4, height / 4, 4),
        &mut out,
    );
    out[0]
}

/// The lost rule's sharpness signals of a `width x height` response map: PSR (with
/// the tracker's 2-cell exclusion) plus APCE.
pub fn sharpness(response: &[f32], width: usize, height: usize) -> f64 {
    peak_to_sidelobe(response, width, height, 2) + average_peak_correlation_energy(response)
}
