//! Reading OTB sequences (Wu, Lim & Yang): `img/0001.jpg ...` and `groundtruth_rect.txt`
//! with one `x y w h` box per line (1-based corner, separated by tabs, commas or spaces).

use std::path::{Path, PathBuf};

use crate::error::{Result, TrackingError};
use crate::frame::BoundingBox;

/// Parses ground-truth text; boxes come back with a 0-based corner. `name` labels errors.
///
/// # Errors
/// [`TrackingError::Parse`] naming `name` and the 1-based line of the first malformed
/// line (not four finite numbers, or a negative width or height). Blank lines inside
/// the file are errors too (a box per frame is expected); blank lines at its end are not.
///
/// # Examples
/// ```
/// use tracking::otb::parse_groundtruth;
///
/// let boxes = parse_groundtruth("57\t21\t31\t45\n58,22,31,43\n", "gt.txt").unwrap();
/// assert_eq!(boxes[1].to_array(), [57.0, 21.0, 31.0, 43.0]);
/// let err = parse_groundtruth("1 2 3 4\n1 2 x 4\n", "gt.txt").unwrap_err();
/// assert!(err.to_string().starts_with("gt.txt:2:"));
/// ```
pub fn parse_groundtruth(text: &str, name: &str) -> Result<Vec<BoundingBox>> {
    // Blank lines at the end of the file are tolerated; a blank line inside is a frame
    // without a box, which is an error.
    let text = text.trim_end_matches(['\n', '\r', ' ', '\t']);
    let mut boxes = Vec::new();
    for (i, line) in text.split('\n').enumerate() {
        let bad = |reason: String| TrackingError::Parse {
            path: name.to_string(),
            line: i + 1,
            reason,
        };
        let fields: Vec<&str> = line
            .trim()
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        if fields.len() != 4 {
            return Err(bad(format!(
                "expected 4 numbers x y w h, got {} fields in {}",
                fields.len(),
                rperc_core::excerpt(line)
            )));
        }
        let mut v = [0.0; 4];
        for (slot, f) in v.iter_mut().zip(&fields) {
            *slot = f
                .parse::<f64>()
                .map_err(|_| bad(format!("{} is not a number", rperc_core::excerpt(f))))?;
            if !slot.is_finite() {
                return Err(bad(format!("{} is not finite", rperc_core::excerpt(f))));
            }
        }
        if v[2] < 0.0 || v[3] < 0.0 {
            return Err(bad(format!(
                "a box cannot have a negative size, got {}",
                rperc_core::excerpt(line)
            )));
        }
        // Both corners within the coordinate range every rperc position has: a box at
        // 1e300 passed as finite, and its IoU and centre error came out as NaN or 0.
        let corners = [v[0], v[1], v[0] + v[2], v[1] + v[3]];
        if corners.iter().any(|c| c.abs() > rperc_core::MAX_COORDINATE) {
            return Err(bad(format!(
                "box corners must be within +-{:e} pixels, got {}",
                rperc_core::MAX_COORDINATE,
                rperc_core::excerpt(line)
            )));
        }
        boxes.push(BoundingBox::new(v[0] - 1.0, v[1] - 1.0, v[2], v[3]));
    }
    Ok(boxes)
}

/// A sequence folder: sorted frame paths and the ground truth (one box per frame).
#[derive(Debug, Clone)]
pub struct OtbSequence {
    /// `img/*.jpg` in name order.
    pub frames: Vec<PathBuf>,
    /// Ground-truth boxes, 0-based corners.
    pub groundtruth: Vec<BoundingBox>,
}

/// Reads `dir/groundtruth_rect.txt` and lists `dir/img/*.jpg`.
///
/// # Errors
/// [`TrackingError::Io`] for a missing file or folder, [`TrackingError::Parse`] for a
/// malformed line, [`TrackingError::LengthMismatch`] when frames and boxes differ in number.
pub fn load_sequence(dir: &Path) -> Result<OtbSequence> {
    let io = |p: &Path, e: std::io::Error| TrackingError::Io {
        path: p.display().to_string(),
        reason: e.to_string(),
    };
    let gt_path = dir.join("groundtruth_rect.txt");
    let text = std::fs::read_to_string(&gt_path).map_err(|e| io(&gt_path, e))?;
    let groundtruth = parse_groundtruth(&text, &gt_path.display().to_string())?;
    let img = dir.join("img");
    let mut frames: Vec<PathBuf> = std::fs::read_dir(&img)
        .map_err(|e| io(&img, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("jpg") || x.eq_ignore_ascii_case("png"))
        })
        .collect();
    frames.sort();
    if frames.len() != groundtruth.len() {
        return Err(TrackingError::LengthMismatch {
            what: format!(
                "{} has {} frames but {} has {} boxes",
                img.display(),
                frames.len(),
                gt_path.display(),
                groundtruth.len()
            ),
        });
    }
    Ok(OtbSequence {
        frames,
        groundtruth,
    })
}

/// Decodes one frame as RGB.
///
/// # Errors
/// [`TrackingError::Io`] naming the file.
pub fn load_frame(path: &Path) -> Result<image::RgbImage> {
    image::open(path)
        .map(|i| i.to_rgb8())
        .map_err(|e| TrackingError::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_file_and_line() {
        let err = parse_groundtruth("1\t2\t3\t4\n\n5 6 7 8\n", "seq/gt.txt").unwrap_err();
        assert_eq!(
            err,
            TrackingError::Parse {
                path: "seq/gt.txt".into(),
                line: 2,
                reason: "expected 4 numbers x y w h, got 0 fields in \"\"".into()
            }
        );
        let err = parse_groundtruth("1 2 3 4\n1 2 3 NaN\n", "g").unwrap_err();
        assert!(matches!(err, TrackingError::Parse { line: 2, .. }));
        let err = parse_groundtruth("1 2 3 4 5\n", "g").unwrap_err();
        assert!(matches!(err, TrackingError::Parse { line: 1, .. }));
    }

    #[test]
    fn corners_beyond_the_coordinate_range_are_refused() {
        for bad in ["1e300 2 3 4", "1 -2e9 3 4", "9e8 1 2e8 4", "1 1 3 1e10"] {
            let text = format!("1 2 3 4\n{bad}\n");
            let err = parse_groundtruth(&text, "g").unwrap_err();
            assert!(
                matches!(err, TrackingError::Parse { line: 2, .. }),
                "{bad}: {err}"
            );
        }
        // The range's edge itself is a box.
        assert!(parse_groundtruth("-1e9 0 2e9 1e9", "g").is_ok());
    }

    #[test]
    fn converts_to_zero_based_and_accepts_crlf() {
        let b = parse_groundtruth("1,1,10,20\r\n2\t3\t4\t5", "g").unwrap();
        assert_eq!(b[0].to_array(), [0.0, 0.0, 10.0, 20.0]);
        assert_eq!(b[1].to_array(), [1.0, 2.0, 4.0, 5.0]);
    }
}
