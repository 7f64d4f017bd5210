//! The few lines `ppkat adjust` prints: size, σ0, groups, additional parameters, what data
//! snooping removed, the check points and the warnings.

use super::results::Results;

impl Results {
    /// A few lines for the terminal.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} images, {} points; {} observations, {} unknowns, redundancy {:.0}; σ0 {:.3}\n",
            self.images.len(),
            self.points.len(),
            self.observations,
            self.unknowns,
            self.redundancy,
            self.sigma0
        );
        for g in &self.groups {
            s += &format!(
                "  {}: {} components, σ factor {:.3}, mean redundancy {:.2}\n",
                g.group, g.observations, g.sigma_factor, g.mean_redundancy
            );
        }
        for e in self
            .lever_arms
            .iter()
            .chain(&self.boresights)
            .chain(&self.drifts)
            .chain(&self.latencies)
            .chain(&self.interiors)
        {
            let v: Vec<String> = e
                .labels
                .iter()
                .zip(e.values.iter().zip(&e.sigmas))
                .map(|(l, (v, sg))| format!("{l} {v:.4} ± {sg:.4}"))
                .collect();
            s += &format!("  {}: {}\n", e.name, v.join(", "));
        }
        if let Some(t) = &self.tight {
            s += &t.lines();
        }
        if let Some(n) = &self.start_note {
            s += &format!("{n}\n");
        }
        s += &format!("removed by data snooping: {}\n", self.removed.len());
        for r in &self.removed {
            s += &format!("  {} (|w| {:.1}) {}\n", r.what, r.w, r.source);
        }
        let c = &self.checks;
        if !c.points.is_empty() {
            s += &format!(
                "check points: {}, RMS E/N/U {:.3} {:.3} {:.3} m, max {:.3} {:.3} {:.3} m, theoretical {:.3} {:.3} {:.3} m\n",
                c.points.len(), c.rms[0], c.rms[1], c.rms[2], c.max[0], c.max[1], c.max[2],
                c.theoretical_rms[0], c.theoretical_rms[1], c.theoretical_rms[2]
            );
        }
        for w in &self.warnings {
            s += &format!("warning: {w}\n");
        }
        s
    }
}
