//! Runs a tracker on an OTB sequence from its first ground-truth box and prints success
//! AUC, precision at 20 px and frames per second (tracking time only: JPEG decoding is
//! excluded).
//!
//!     track_otb SEQ_DIR [--tracker colour|particles] [--seed N] [--set name=value ...]
//!
//! `--set` overrides a parameter for tuning (e.g. `--set search_radius=10`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use tracking::metrics::{auc, centre_error, iou, precision};
use tracking::otb::{load_frame, load_sequence};
use tracking::{
    BoundingBox, ColorHistogramTracker, ColorSpace, ColorTrackerParams, ModelKind,
    ParticleColorTracker, ParticleTrackerParams, RgbFrame, TrackResult, TrackingError,
};

enum Tracker {
    Colour(Box<ColorHistogramTracker>),
    Particles(Box<ParticleColorTracker>),
}

impl Tracker {
    fn update(&mut self, frame: RgbFrame<'_>) -> Result<TrackResult, TrackingError> {
        match self {
            Tracker::Colour(t) => t.update(frame),
            Tracker::Particles(t) => t.update(frame),
        }
    }
}

fn set_param(
    c: &mut ColorTrackerParams,
    p: &mut ParticleTrackerParams,
    kv: &str,
) -> Result<(), String> {
    let (k, v) = kv
        .split_once('=')
        .ok_or_else(|| format!("--set expects name=value, got {kv}"))?;
    let f = || {
        v.parse::<f64>()
            .map_err(|_| format!("{k}: {v} is not a number"))
    };
    let app = [&mut c.appearance, &mut p.appearance];
    match k {
        "color_space" => {
            let s = match v {
                "rgb" => ColorSpace::Rgb,
                "opponent" => ColorSpace::Opponent,
                "rg" => ColorSpace::NormalizedRg,
                "hsv" => ColorSpace::Hsv,
                _ => return Err(format!("unknown colour space {v}")),
            };
            app.into_iter().for_each(|a| a.color_space = s);
        }
        "bins" => {
            let b: Vec<usize> = v.split(',').filter_map(|x| x.parse().ok()).collect();
            let b: [usize; 3] = b.try_into().map_err(|_| "bins=a,b,c".to_string())?;
            app.into_iter().for_each(|a| a.bins = b);
        }
        "model" => {
            let m = if v == "single" {
                ModelKind::Single
            } else {
                ModelKind::Bimodal {
                    upper_fraction: f()?,
                }
            };
            app.into_iter().for_each(|a| a.model = m);
        }
        "adaptation_rate" => app
            .into_iter()
            .for_each(|a| a.adaptation_rate = v.parse().unwrap_or(f64::NAN)),
        "adaptation_threshold" => app
            .into_iter()
            .for_each(|a| a.adaptation_threshold = v.parse().unwrap_or(f64::NAN)),
        "gradient_weight" => app
            .into_iter()
            .for_each(|a| a.gradient_weight = v.parse().unwrap_or(f64::NAN)),
        "lost_threshold" => app
            .into_iter()
            .for_each(|a| a.lost_threshold = v.parse().unwrap_or(f64::NAN)),
        "search_radius" => c.search_radius = f()? as usize,
        "scale_step" => c.scale_step = f()?,
        "momentum" => c.momentum = f()?,
        "min_scale" => (c.min_scale, p.min_scale) = (f()?, f()?),
        "max_scale" => (c.max_scale, p.max_scale) = (f()?, f()?),
        "parallel" => (c.parallel, p.filter.parallel) = (v == "true", v == "true"),
        "n_particles" => p.n_particles = f()? as usize,
        "position_noise" => p.position_noise = f()?,
        "scale_noise" => p.scale_noise = f()?,
        "sigma" => p.sigma = f()?,
        _ => return Err(format!("unknown parameter {k}")),
    }
    Ok(())
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut dir = None;
    let mut kind = "colour".to_string();
    let mut seed = 0u64;
    let mut cp = ColorTrackerParams::default();
    let mut pp = ParticleTrackerParams::default();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--tracker" => kind = args.next().ok_or("--tracker needs a value")?,
            "--seed" => {
                seed = args
                    .next()
                    .and_then(|s| s.parse().ok())
                    .ok_or("--seed needs an integer")?
            }
            "--set" => set_param(
                &mut cp,
                &mut pp,
                &args.next().ok_or("--set needs name=value")?,
            )?,
            "-h" | "--help" => {
                println!(
                    "usage: track_otb SEQ_DIR [--tracker colour|particles] [--seed N] [--set name=value]..."
                );
                return Ok(());
            }
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let dir = dir.ok_or(
        "usage: track_otb SEQ_DIR [--tracker colour|particles] [--seed N] [--set name=value]...",
    )?;
    let seq = load_sequence(&dir).map_err(|e| e.to_string())?;
    let images = seq
        .frames
        .iter()
        .map(|p| load_frame(p))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let first = RgbFrame::from_image(&images[0]).map_err(|e| e.to_string())?;
    let gt = &seq.groundtruth;

    let start = Instant::now();
    let mut tracker = match kind.as_str() {
        "colour" => Tracker::Colour(Box::new(
            ColorHistogramTracker::new(first, gt[0], cp).map_err(|e| e.to_string())?,
        )),
        "particles" => Tracker::Particles(Box::new(
            ParticleColorTracker::new(first, gt[0], pp, seed).map_err(|e| e.to_string())?,
        )),
        _ => return Err(format!("unknown tracker {kind}")),
    };
    let mut boxes: Vec<BoundingBox> = vec![gt[0]];
    let mut n_lost = 0;
    for img in &images[1..] {
        let r = tracker
            .update(RgbFrame::from_image(img).map_err(|e| e.to_string())?)
            .map_err(|e| e.to_string())?;
        n_lost += usize::from(r.lost);
        boxes.push(r.bbox);
    }
    let elapsed = start.elapsed().as_secs_f64();

    let overlaps: Vec<f64> = boxes.iter().zip(gt).map(|(b, g)| iou(b, g)).collect();
    let errors: Vec<f64> = boxes
        .iter()
        .zip(gt)
        .map(|(b, g)| centre_error(b, g))
        .collect();
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    println!(
        "{name}: tracker {kind}, {} frames {}x{}: AUC {:.3}, precision@20px {:.3}, {:.0} fps, lost in {n_lost} frames",
        images.len(),
        images[0].width(),
        images[0].height(),
        auc(&overlaps),
        precision(&errors, 20.0),
        images.len() as f64 / elapsed,
    );
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("track_otb: {e}");
            ExitCode::FAILURE
        }
    }
}
