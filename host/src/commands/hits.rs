//! `kdray hits`: a hits file (`kdray trace --out`) as text, so that it can be read, diffed and
//! grepped without a hex dump.

use kdray::error::{Error, Result};
use kdray::{files, rays};
use std::io::{Read as _, Seek as _, Write as _};
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
/// (floats in Rust's shortest form that reads back to the same bits), or `INDEX miss`. Reads only
/// those records (a hits file may be larger than memory).
///
/// # Errors
/// The file is not a whole number of hits, `--first` is past its end, reading it or writing to
/// stdout fails (a closed pipe just ends the listing).
pub fn hits(args: &HitsArgs) -> Result<()> {
    let path = &args.file;
    let mut file = files::open(path)?;
    let bytes = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let n = rays::record_count(path, bytes, rays::HIT_BYTES, "hits")?;
    let first = args.first as u64;
    if first > 0 && first >= n {
        let msg = format!("holds {n} hits: --first {first} is past its end");
        return Err(Error::new(path, msg));
    }
    let end = args
        .count
        .map_or(n, |c| first.saturating_add(c as u64).min(n));
    file.seek(std::io::SeekFrom::Start(first * rays::HIT_BYTES as u64))
        .map_err(|e| Error::io(path, e))?;
    let mut records = std::io::BufReader::new(file);
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut record = [0u8; rays::HIT_BYTES];
    for i in first..end {
        records
            .read_exact(&mut record)
            .map_err(|e| Error::io(path, e))?;
        let h = rays::decode_hit(&record);
        let line = if h.is_hit() {
            writeln!(out, "{i} t={} prim={} u={} v={}", h.t, h.prim, h.u, h.v)
        } else {
            writeln!(out, "{i} miss")
        };
        if !written(line)? {
            return Ok(());
        }
    }
    written(out.flush()).map(|_| ())
}

/// Whether a write to stdout went through: false for a closed pipe (`kdray hits FILE | head`),
/// which ends the listing without error.
fn written(r: std::io::Result<()>) -> Result<bool> {
    match r {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(false),
        Err(e) => Err(Error::new("<stdout>", e.to_string())),
        Ok(()) => Ok(true),
    }
}
