//! `kdray hits`: a hits file (`kdray trace --out`) as text, so that it can be read, diffed and
//! grepped without a hex dump.

use kdray::error::{Error, Result};
use kdray::{files, rays};
use std::io::Write as _;
use std::path::PathBuf;

/// `kdray hits`'s arguments.
#[derive(clap::Args, Debug)]
pub struct HitsArgs {
    /// The hits file: n × (f32 t, u32 prim, f32 u, f32 v), little-endian, one per ray in the
    /// rays file's order.
    #[arg(value_name = "HITS.bin")]
    pub file: PathBuf,
    /// The index of the first hit to print.
    #[arg(long, default_value_t = 0)]
    pub first: usize,
    /// How many hits to print (default: all from --first on).
    #[arg(long)]
    pub count: Option<usize>,
}

/// Prints the hits `first..first + count` of the file, one line each: `INDEX t=T prim=P u=U v=V`
/// (floats in Rust's shortest form that reads back to the same bits), or `INDEX miss`.
pub fn hits(args: &HitsArgs) -> Result<()> {
    let hits = rays::decode_hits(&args.file, &files::read(&args.file)?)?;
    let end = args
        .count
        .map_or(hits.len(), |n| args.first.saturating_add(n).min(hits.len()));
    let write = || -> std::io::Result<()> {
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        for (i, h) in hits.iter().enumerate().take(end).skip(args.first) {
            if h.is_hit() {
                writeln!(out, "{i} t={} prim={} u={} v={}", h.t, h.prim, h.u, h.v)?;
            } else {
                writeln!(out, "{i} miss")?;
            }
        }
        out.flush()
    };
    match write() {
        // A closed pipe (`kdray hits FILE | head`) ends the listing; it is not an error.
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(Error::new("<stdout>", e.to_string()))
        }
        _ => Ok(()),
    }
}
