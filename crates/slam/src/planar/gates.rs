//! The chi-square gates the association tests against: one detection's (2 degrees
//! of freedom), and `k` stacked detections' (`2k`) for JCBB's joint test, computed
//! as scans with more detections come.

use rperc_core::chi2_gate;

use crate::error::Result;

/// The gates at one confidence.
#[derive(Debug, Clone)]
pub(super) struct Gates {
    confidence: f64,
    /// `joint[k]`: the gate of `k` stacked detections (`joint[1]`, one detection's).
    joint: Vec<f64>,
}

impl Gates {
    /// The gates at `confidence` (a probability in (0, 1)).
    pub fn new(confidence: f64) -> Result<Self> {
        let individual = chi2_gate(2, confidence)?;
        Ok(Self {
            confidence,
            joint: vec![0.0, individual],
        })
    }

    /// One detection's gate on its normalised innovation squared.
    pub fn individual(&self) -> f64 {
        self.joint[1]
    }

    /// Makes `joint()[k]` available for every `k <= n`.
    pub fn grow(&mut self, n: usize) -> Result<()> {
        while self.joint.len() <= n {
            let k = self.joint.len();
            self.joint.push(chi2_gate(2 * k, self.confidence)?);
        }
        Ok(())
    }

    /// `joint()[k]`, the gate of `k` stacked detections, for every `k` grown so far.
    pub fn joint(&self) -> &[f64] {
        &self.joint
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gates_are_the_chi_square_quantiles_of_2k_degrees_of_freedom() {
        // Closed form for 2 degrees of freedom: the quantile of p is -2 ln(1 - p).
        let mut gates = Gates::new(0.95).unwrap();
        assert!((gates.individual() - (-2.0 * 0.05f64.ln())).abs() < 1e-9);
        gates.grow(3).unwrap();
        assert_eq!(gates.joint().len(), 4);
        assert_eq!(gates.joint()[1], gates.individual());
        for k in 1..4 {
            assert_eq!(gates.joint()[k], chi2_gate(2 * k, 0.95).unwrap());
        }
        gates.grow(2).unwrap(); // already there: nothing changes
        assert_eq!(gates.joint().len(), 4);
    }
}
