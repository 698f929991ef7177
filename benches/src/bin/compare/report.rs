//! `compare`'s output: per framing, a line on its rays, the table (the same columns as before
//! the tight framing existed) and one summary line per kind of ray.

use kdray_benches::setup::RaySets;

/// Whose traversal a row measures: the summary lines compare the best kdray row with the best
/// Embree row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Kdray,
    Bvh,
    Embree,
}

/// One tracer's figures for every ray set, in the order of [`set_index`].
pub struct Row {
    pub name: String,
    pub family: Family,
    pub build_ms: Option<f64>,
    pub mrays: Vec<f64>,
    pub mismatches: Vec<usize>,
}

/// The kinds of ray in each framing, in the order their sets are traced.
pub const KINDS: [&str; 2] = ["primary", "diffuse"];

/// Where framing `f`'s rays of kind `k` (an index into [`KINDS`]) are in a [`Row`].
pub fn set_index(f: usize, k: usize) -> usize {
    f * KINDS.len() + k
}

/// The best row of `family` on set `s`, by median Mrays/s.
fn best(rows: &[Row], family: Family, s: usize) -> Option<&Row> {
    rows.iter()
        .filter(|r| r.family == family)
        .max_by(|a, b| a.mrays[s].total_cmp(&b.mrays[s]))
}

/// The summary line of set `s`: kdray's best row against Embree's best, and their ratio.
pub fn summary(rows: &[Row], s: usize, label: &str) -> String {
    let kdray = best(rows, Family::Kdray, s).map_or("kdray: no rows".into(), |r| {
        format!("kdray best {:.2} Mrays/s ({})", r.mrays[s], r.name)
    });
    let embree = match best(rows, Family::Embree, s) {
        None => "Embree: not built (no `embree` feature), no ratio".to_string(),
        Some(e) => {
            let ratio = best(rows, Family::Kdray, s).map(|k| k.mrays[s] / e.mrays[s]);
            format!(
                "Embree best {:.2} Mrays/s ({}), ratio kdray/Embree {}",
                e.mrays[s],
                e.name,
                ratio.map_or("-".into(), |x| format!("{x:.2}"))
            )
        }
    };
    format!("{label}: {kdray}; {embree}")
}

/// The whole report of one mesh.
pub fn print(mesh: &str, triangles: usize, repeat: usize, sets: &[RaySets], rows: &[Row]) {
    println!(
        "mesh {mesh} ({triangles} triangles), 1 thread, median of {repeat}, kdray {}",
        kdray::cpu::describe()
    );
    for (f, set) in sets.iter().enumerate() {
        let name = set.framing.name();
        println!();
        println!(
            "framing {name} ({}): {} primary rays, {:.1} % hit the mesh; {} diffuse rays",
            set.framing.description(),
            set.primary.len(),
            100.0 * set.hit_fraction(),
            set.diffuse.len(),
        );
        println!(
            "| tracer | build ms | primary Mrays/s | diffuse Mrays/s | primary mismatches | diffuse mismatches |"
        );
        println!("|---|---:|---:|---:|---:|---:|");
        let (p, d) = (set_index(f, 0), set_index(f, 1));
        for r in rows {
            let build = r.build_ms.map_or("-".to_string(), |ms| format!("{ms:.0}"));
            println!(
                "| {} | {build} | {:.2} | {:.2} | {} | {} |",
                r.name, r.mrays[p], r.mrays[d], r.mismatches[p], r.mismatches[d]
            );
        }
        for (k, kind) in KINDS.iter().enumerate() {
            println!(
                "{}",
                summary(rows, set_index(f, k), &format!("{name} {kind}"))
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, family: Family, mrays: [f64; 2]) -> Row {
        Row {
            name: name.into(),
            family,
            build_ms: None,
            mrays: mrays.to_vec(),
            mismatches: vec![0; 2],
        }
    }

    #[test]
    fn summary_takes_each_familys_best_row() {
        let rows = [
            row("kdray scalar", Family::Kdray, [5.0, 1.0]),
            row("kdray packet 8", Family::Kdray, [20.0, 1.5]),
            row("bvh crate", Family::Bvh, [90.0, 90.0]),
            row("embree rtcIntersect1", Family::Embree, [10.0, 3.0]),
            row("embree rtcIntersect8", Family::Embree, [16.0, 2.0]),
        ];
        assert_eq!(
            summary(&rows, 0, "loose primary"),
            "loose primary: kdray best 20.00 Mrays/s (kdray packet 8); \
             Embree best 16.00 Mrays/s (embree rtcIntersect8), ratio kdray/Embree 1.25"
        );
        assert_eq!(
            summary(&rows, 1, "loose diffuse"),
            "loose diffuse: kdray best 1.50 Mrays/s (kdray packet 8); \
             Embree best 3.00 Mrays/s (embree rtcIntersect1), ratio kdray/Embree 0.50"
        );
    }

    #[test]
    fn summary_without_embree_says_so() {
        let rows = [row("kdray scalar", Family::Kdray, [5.0, 1.0])];
        assert_eq!(
            summary(&rows, 0, "tight primary"),
            "tight primary: kdray best 5.00 Mrays/s (kdray scalar); \
             Embree: not built (no `embree` feature), no ratio"
        );
    }
}
