//! `kdray merge`: reassembles the row bands that `kdray render --tile K/N` wrote into one image.

use kdray::error::Result;
use kdray::image::{self, Band};
use std::path::{Path, PathBuf};

/// Reads every part, checks that they tile the image exactly once, and writes the image.
pub fn merge(parts: &[PathBuf], out: &Path) -> Result<()> {
    image::Format::of(out)?;
    let inputs: Vec<&Path> = parts.iter().map(PathBuf::as_path).collect();
    kdray::files::check_outputs(&inputs, &[out])?;
    let bands = parts
        .iter()
        .map(|p| Ok((p.as_path(), image::read_exr(p)?)))
        .collect::<Result<Vec<(&Path, Band)>>>()?;
    let whole = image::merge(&bands)?;
    image::write(out, &whole)?;
    println!(
        "wrote {}: {}x{} from {} parts",
        out.display(),
        whole.width,
        whole.height,
        parts.len()
    );
    Ok(())
}
