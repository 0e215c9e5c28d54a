//! The build report of a [`SparseBoxes`] (`Structure::report`): its cost figure and extra columns.

use crate::{SparseBoxes, PAPER_BOX_BYTES, TEXT_BOX_BYTES};
use tb_core::{Accel, BuildReport};

impl SparseBoxes {
    /// The kd-tree's figures, then `d_min`, `n_b` (N_B), `m_kd_bytes` (M_KD as the text of §4
    /// prices a box: 8 bytes per node, 4 per reference, 24 + 4 per augmented node,
    /// [`TEXT_BOX_BYTES`]), `m_kd_htr_bytes` (the same without boxes: HTR's and SEQ's M_KD),
    /// `paper_bytes` (M_KD of BTR and SLTR as Table 1 counts it: [`PAPER_BOX_BYTES`] per box),
    /// `paper_ratio` (`paper_bytes / m_kd_htr_bytes`: Table 1's M_KD of BTR over HTR's, one
    /// row's key since a claim cannot divide two), `aug_bytes` (our real bytes of the boxes,
    /// links, node indices, depths and rank).
    pub(crate) fn report_figures(&self) -> BuildReport {
        let mut r = Accel::build_report(&self.kd);
        let v = self.kd.view();
        let base = (8 * v.nodes().len() + 4 * v.refs().len()) as f64;
        let nb = self.aug.len() as f64;
        let paper = base + PAPER_BOX_BYTES as f64 * nb;
        r.extra.extend([
            ("d_min".into(), self.params.d_min as f64),
            ("n_b".into(), nb),
            ("m_kd_bytes".into(), base + TEXT_BOX_BYTES as f64 * nb),
            ("m_kd_htr_bytes".into(), base),
            ("paper_bytes".into(), paper),
            (
                "paper_ratio".into(),
                if base > 0.0 { paper / base } else { 1.0 },
            ),
            ("aug_bytes".into(), self.boxes_bytes() as f64),
        ]);
        r
    }
}
