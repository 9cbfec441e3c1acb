//! The OTB evaluation metrics (Wu, Lim & Yang 2013): overlap (IoU), the success curve
//! and its area over 21 thresholds, and precision at a centre-error threshold.

use crate::frame::BoundingBox;

/// The 21 success-curve thresholds 0, 0.05, ..., 1.
pub fn success_thresholds() -> [f64; 21] {
    std::array::from_fn(|i| i as f64 / 20.0)
}

/// Intersection over union of two boxes; 0 when either has a non-positive or
/// non-finite size (a lost target).
///
/// # Examples
/// ```
/// use tracking::BoundingBox;
/// use tracking::metrics::iou;
///
/// let a = BoundingBox::new(0.0, 0.0, 2.0, 2.0);
/// let b = BoundingBox::new(1.0, 0.0, 2.0, 2.0);
/// assert!((iou(&a, &b) - 2.0 / 6.0).abs() < 1e-12);
/// ```
pub fn iou(a: &BoundingBox, b: &BoundingBox) -> f64 {
    let valid =
        |r: &BoundingBox| r.to_array().iter().all(|v| v.is_finite()) && r.w > 0.0 && r.h > 0.0;
    if !valid(a) || !valid(b) {
        return 0.0;
    }
    let iw = ((a.x + a.w).min(b.x + b.w) - a.x.max(b.x)).max(0.0);
    let ih = ((a.y + a.h).min(b.y + b.h) - a.y.max(b.y)).max(0.0);
    let inter = iw * ih;
    let union = a.w * a.h + b.w * b.h - inter;
    // Round-off can put identical boxes a hair above 1, past the last success threshold.
    if union > 0.0 {
        (inter / union).min(1.0)
    } else {
        0.0
    }
}

/// Fraction of `overlaps` strictly above each of the 21 thresholds.
pub fn success_curve(overlaps: &[f64]) -> [f64; 21] {
    let n = overlaps.len().max(1) as f64;
    success_thresholds().map(|t| overlaps.iter().filter(|&&o| o > t).count() as f64 / n)
}

/// Area under the success curve: its mean over the 21 thresholds.
///
/// # Examples
/// ```
/// use tracking::metrics::auc;
///
/// // IoU 0.5 exceeds the thresholds 0, 0.05, ..., 0.45: 10 of 21.
/// assert!((auc(&[0.5]) - 10.0 / 21.0).abs() < 1e-12);
/// ```
pub fn auc(overlaps: &[f64]) -> f64 {
    success_curve(overlaps).iter().sum::<f64>() / 21.0
}

/// Distance in pixels between the centres of two boxes (infinite if either is not finite).
pub fn centre_error(a: &BoundingBox, b: &BoundingBox) -> f64 {
    let ((ax, ay), (bx, by)) = (a.centre(), b.centre());
    let d = (ax - bx).hypot(ay - by);
    if d.is_finite() { d } else { f64::INFINITY }
}

/// Fraction of frames whose centre error is at most `threshold` pixels (20 in OTB).
pub fn precision(errors: &[f64], threshold: f64) -> f64 {
    errors.iter().filter(|&&e| e <= threshold).count() as f64 / errors.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(x: f64, y: f64, w: f64, h: f64) -> BoundingBox {
        BoundingBox::new(x, y, w, h)
    }

    #[test]
    fn iou_hand_computed() {
        assert_eq!(iou(&b(0.0, 0.0, 10.0, 10.0), &b(0.0, 0.0, 10.0, 10.0)), 1.0);
        // Corner overlap 5 x 5 = 25; union 100 + 100 - 25 = 175.
        assert!(
            (iou(&b(0.0, 0.0, 10.0, 10.0), &b(5.0, 5.0, 10.0, 10.0)) - 25.0 / 175.0).abs() < 1e-12
        );
        // Contained 2 x 3 in 4 x 6: 6 / 24.
        assert!((iou(&b(0.0, 0.0, 4.0, 6.0), &b(1.0, 1.0, 2.0, 3.0)) - 0.25).abs() < 1e-12);
        // Touching edges and disjoint boxes: 0.
        assert_eq!(iou(&b(0.0, 0.0, 1.0, 1.0), &b(1.0, 0.0, 1.0, 1.0)), 0.0);
        assert_eq!(iou(&b(0.0, 0.0, 1.0, 1.0), &b(5.0, 5.0, 1.0, 1.0)), 0.0);
        // Degenerate or NaN boxes: 0.
        assert_eq!(iou(&b(0.0, 0.0, 0.0, 1.0), &b(0.0, 0.0, 1.0, 1.0)), 0.0);
        assert_eq!(
            iou(&b(f64::NAN, 0.0, 1.0, 1.0), &b(0.0, 0.0, 1.0, 1.0)),
            0.0
        );
    }

    #[test]
    fn success_and_auc_hand_computed() {
        // Overlaps 0, 0.5, 1: above t = 0 are two (0.5 and 1); above 0.05..0.45 two;
        // above 0.5..0.95 one; above 1 none.
        let curve = success_curve(&[0.0, 0.5, 1.0]);
        assert_eq!(curve[0], 2.0 / 3.0);
        assert_eq!(curve[9], 2.0 / 3.0);
        assert_eq!(curve[10], 1.0 / 3.0);
        assert_eq!(curve[19], 1.0 / 3.0);
        assert_eq!(curve[20], 0.0);
        // AUC = (10 * 2/3 + 10 * 1/3 + 0) / 21 = 10 / 21.
        assert!((auc(&[0.0, 0.5, 1.0]) - 10.0 / 21.0).abs() < 1e-12);
        // A perfect tracker: IoU 1 is above every threshold but 1 itself.
        assert!((auc(&[1.0; 4]) - 20.0 / 21.0).abs() < 1e-12);
    }

    #[test]
    fn precision_hand_computed() {
        // Centres (5, 5) and (8, 9): distance 5.
        let e = centre_error(&b(0.0, 0.0, 10.0, 10.0), &b(3.0, 4.0, 10.0, 10.0));
        assert!((e - 5.0).abs() < 1e-12);
        assert_eq!(precision(&[5.0, 20.0, 20.5, f64::INFINITY], 20.0), 0.5);
        assert_eq!(
            centre_error(&b(f64::NAN, 0.0, 1.0, 1.0), &b(0.0, 0.0, 1.0, 1.0)),
            f64::INFINITY
        );
    }
}
