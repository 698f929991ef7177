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
    /// The instance ids file that `kdray trace --instances` wrote beside the hits (n × u32):
    /// each hit's line then ends with `instance=I`.
    #[arg(long, value_name = "IDS.bin")]
    pub instances: Option<PathBuf>,
}

/// Prints the hits `first..first + count` of the file, one line each: `INDEX t=T prim=P u=U v=V`
/// (floats in Rust's shortest form that reads back to the same bits), with ` instance=I` after
/// it when `--instances` is given, or `INDEX miss`. Reads only those records (a hits file may be
/// larger than memory).
///
/// # Errors
/// The file is not a whole number of hits, `--first` is past its end, the instance ids file does
/// not hold one id per hit, reading either or writing to stdout fails (a closed pipe just ends
/// the listing).
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
    let mut ids = match &args.instances {
        Some(ids_path) => {
            let mut f = files::open(ids_path)?;
            let len = f.metadata().map_err(|e| Error::io(ids_path, e))?.len();
            if len != n * 4 {
                let msg = format!("holds {len} bytes: expected one u32 for each of {n} hits");
                return Err(Error::new(ids_path, msg));
            }
            f.seek(std::io::SeekFrom::Start(first * 4))
                .map_err(|e| Error::io(ids_path, e))?;
            Some((ids_path, std::io::BufReader::new(f)))
        }
        None => None,
    };
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let mut record = [0u8; rays::HIT_BYTES];
    for i in first..end {
        records
            .read_exact(&mut record)
            .map_err(|e| Error::io(path, e))?;
        let h = rays::decode_hit(&record);
        let instance = match &mut ids {
            Some((ids_path, reader)) => {
                let mut id = [0u8; 4];
                reader
                    .read_exact(&mut id)
                    .map_err(|e| Error::io(ids_path, e))?;
                format!(" instance={}", u32::from_le_bytes(id))
            }
            None => String::new(),
        };
        let line = if h.is_hit() {
            writeln!(
                out,
                "{i} t={} prim={} u={} v={}{instance}",
                h.t, h.prim, h.u, h.v
            )
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
