//! `compare`'s command line. Every value is checked: a bad one is a usage error (exit 2, as
//! kdray's command line does, docs/FORMATS.md), never a silent default.

use std::path::PathBuf;

pub const USAGE: &str = "usage: kdray-compare MESH [--repeat N] [--size WxH]
  --repeat N   timed runs per tracer and ray set, the median reported (default 5, N >= 1)
  --size WxH   the image, one primary ray per pixel (default 1024x1024)";

/// The most rays one primary set may have: 2²⁶ rays are 2 GiB, and the comparison holds two
/// primary sets, their bounces and a hit buffer per set at once.
pub const MAX_PIXELS: u64 = 1 << 26;

/// What the command line asks for.
#[derive(Debug, PartialEq)]
pub enum Command {
    Run(Args),
    Help,
}

#[derive(Debug, PartialEq)]
pub struct Args {
    pub mesh: PathBuf,
    pub repeat: usize,
    pub size: (u32, u32),
}

/// Parses the arguments after the program name.
///
/// # Errors
/// What is wrong, for a usage message: an unknown option, an option without its value, a value
/// that does not parse or is out of range, no mesh or more than one.
pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Command, String> {
    let mut args = args.into_iter();
    let (mut mesh, mut repeat, mut size) = (None, 5usize, (1024u32, 1024u32));
    while let Some(a) = args.next() {
        match a.as_str() {
            "-h" | "--help" => return Ok(Command::Help),
            "--repeat" => repeat = parse_repeat(&value(&a, args.next())?)?,
            "--size" => size = parse_size(&value(&a, args.next())?)?,
            _ if a.starts_with('-') => return Err(format!("unknown option '{a}'")),
            _ if mesh.is_some() => {
                return Err(format!("one mesh at a time ('{a}' is a second one)"));
            }
            _ => mesh = Some(PathBuf::from(a)),
        }
    }
    let mesh = mesh.ok_or("no mesh given")?;
    Ok(Command::Run(Args { mesh, repeat, size }))
}

fn value(option: &str, v: Option<String>) -> Result<String, String> {
    v.ok_or_else(|| format!("{option} needs a value"))
}

fn parse_repeat(v: &str) -> Result<usize, String> {
    match v.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!(
            "--repeat '{v}': expected a whole number of runs, at least 1"
        )),
    }
}

fn parse_size(v: &str) -> Result<(u32, u32), String> {
    let bad = || format!("--size '{v}': expected WxH, two whole numbers of pixels, e.g. 1024x1024");
    let (w, h) = v.split_once('x').ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.parse().map_err(|_| bad())?, h.parse().map_err(|_| bad())?);
    if w == 0 || h == 0 {
        return Err(format!(
            "--size '{v}': the image needs at least one pixel each way"
        ));
    }
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(format!("--size '{v}': more than {MAX_PIXELS} pixels"));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(line: &str) -> Result<Command, String> {
        parse(line.split_whitespace().map(String::from))
    }

    #[test]
    fn defaults_and_values() {
        let run = |mesh: &str, repeat, size| {
            Ok(Command::Run(Args {
                mesh: PathBuf::from(mesh),
                repeat,
                size,
            }))
        };
        assert_eq!(parse_str("m.ply"), run("m.ply", 5, (1024, 1024)));
        assert_eq!(
            parse_str("--repeat 3 m.ply --size 64x32"),
            run("m.ply", 3, (64, 32))
        );
        assert_eq!(parse_str("m.ply --help"), Ok(Command::Help));
    }

    #[test]
    fn bad_values_are_errors() {
        for line in [
            "",
            "m.ply --repeat",
            "m.ply --repeat 0",
            "m.ply --repeat -1",
            "m.ply --repeat five",
            "m.ply --repeat 2.5",
            "m.ply --size",
            "m.ply --size 1024",
            "m.ply --size 0x10",
            "m.ply --size 10x",
            "m.ply --size x10",
            "m.ply --size 10x10x10",
            "m.ply --size -4x4",
            "m.ply --size 65536x65536",
            "m.ply --sizes 4x4",
            "a.ply b.ply",
        ] {
            assert!(parse_str(line).is_err(), "'{line}' was accepted");
        }
    }
}
