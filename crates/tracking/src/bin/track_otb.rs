//! Runs a tracker on an OTB sequence from its first ground-truth box and prints success
//! AUC, precision at 20 px and frames per second (tracking time only: JPEG decoding is
//! excluded).
//!
//!     track_otb SEQ_DIR [--tracker colour|particles] [--seed N] [--config JSON]
//!
//! `--config` overrides parameters with the tracker's config as JSON, the same fields
//! the Python keywords use, e.g. `--config '{"search_radius": 15, "appearance":
//! {"color_space": "rgb"}}'`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use tracking::metrics::{auc, centre_error, iou, precision};
use tracking::otb::{load_frame, load_sequence};
use tracking::{
    BoundingBox, ColorHistogramTracker, ColorTrackerParams, ParticleColorTracker,
    ParticleTrackerParams, RgbFrame, TrackResult, TrackingError, frame_from_image,
};

/// Which tracker runs.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum Kind {
    /// Birchfield's local search.
    Colour,
    /// CONDENSATION over (x, y, scale).
    Particles,
}

/// Run a tracker on an OTB sequence and print AUC, precision@20px and fps.
#[derive(Debug, Parser)]
#[command(name = "track_otb")]
struct Args {
    /// OTB sequence folder (img/, groundtruth_rect.txt).
    sequence: PathBuf,
    /// Which tracker runs.
    #[arg(long, value_enum, default_value = "colour")]
    tracker: Kind,
    /// Seed of the particle filter.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Tracker parameters as JSON (fields of ColorTrackerParams / ParticleTrackerParams).
    #[arg(long, default_value = "{}")]
    config: String,
}

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

    fn start(args: &Args, first: RgbFrame<'_>, b: BoundingBox) -> Result<Self, String> {
        let bad = |e: serde_json::Error| format!("--config: {e}");
        Ok(match args.tracker {
            Kind::Colour => {
                let cp: ColorTrackerParams = serde_json::from_str(&args.config).map_err(bad)?;
                Tracker::Colour(Box::new(
                    ColorHistogramTracker::new(first, b, cp).map_err(|e| e.to_string())?,
                ))
            }
            Kind::Particles => {
                let pp: ParticleTrackerParams = serde_json::from_str(&args.config).map_err(bad)?;
                Tracker::Particles(Box::new(
                    ParticleColorTracker::new(first, b, pp, args.seed)
                        .map_err(|e| e.to_string())?,
                ))
            }
        })
    }
}

fn run(args: &Args) -> Result<(), String> {
    let seq = load_sequence(&args.sequence).map_err(|e| e.to_string())?;
    let images = seq
        .frames
        .iter()
        .map(|p| load_frame(p))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let first = frame_from_image(&images[0]).map_err(|e| e.to_string())?;
    let gt = &seq.groundtruth;

    let start = Instant::now();
    let mut tracker = Tracker::start(args, first, gt[0])?;
    let mut boxes: Vec<BoundingBox> = vec![gt[0]];
    let mut n_lost = 0;
    for img in &images[1..] {
        let r = tracker
            .update(frame_from_image(img).map_err(|e| e.to_string())?)
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
    let name = args
        .sequence
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    println!(
        "{name}: tracker {:?}, {} frames {}x{}: AUC {:.3}, precision@20px {:.3}, {:.0} fps, lost in {n_lost} frames",
        args.tracker,
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
    match run(&Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("track_otb: {e}");
            ExitCode::FAILURE
        }
    }
}
