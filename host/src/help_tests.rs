//! The command line's help: every argument of every subcommand says what it is, and no help text
//! names anything a user cannot see (paths outside the repository, internal jargon).

use super::Cli;
use clap::CommandFactory;

/// Every help text of `cmd` and its subcommands, with the path of names leading to it.
fn walk(cmd: &clap::Command, path: &str, out: &mut Vec<(String, Option<String>)>) {
    let about = cmd
        .get_long_about()
        .or(cmd.get_about())
        .map(|s| s.to_string());
    out.push((path.to_string(), about));
    for arg in cmd.get_arguments() {
        // clap's own --help and --version describe themselves.
        if matches!(arg.get_id().as_str(), "help" | "version") {
            continue;
        }
        let help = arg
            .get_long_help()
            .or(arg.get_help())
            .map(|s| s.to_string());
        out.push((format!("{path} {}", arg.get_id()), help));
    }
    for sub in cmd.get_subcommands() {
        if sub.get_name() == "help" {
            continue;
        }
        walk(sub, &format!("{path} {}", sub.get_name()), out);
    }
}

fn help_texts() -> Vec<(String, Option<String>)> {
    let mut out = Vec::new();
    walk(&Cli::command(), "kdray", &mut out);
    out
}

/// `--help` and `-h` of `cmd` and of each of its subcommands, as printed.
fn printed_helps(cmd: &mut clap::Command, path: &str, out: &mut Vec<(String, String)>) {
    out.push((format!("{path} --help"), cmd.render_long_help().to_string()));
    out.push((format!("{path} -h"), cmd.render_help().to_string()));
    for sub in cmd.get_subcommands_mut() {
        let name = format!("{path} {}", sub.get_name());
        printed_helps(sub, &name, out);
    }
}

/// Doc comments become help text: rustdoc's link syntax (``[`fast`]``) must not reach it.
#[test]
fn no_help_shows_rustdoc_link_syntax() {
    let mut helps = Vec::new();
    printed_helps(&mut Cli::command(), "kdray", &mut helps);
    assert!(helps.iter().any(|(p, _)| p == "kdray build --help"));
    for (path, help) in helps {
        assert!(
            !help.contains("[`"),
            "{path} shows rustdoc link syntax:\n{help}"
        );
    }
}

#[test]
fn the_command_line_is_well_formed() {
    Cli::command().debug_assert();
}

#[test]
fn every_subcommand_and_argument_has_help() {
    let texts = help_texts();
    // The walk reaches every subcommand's arguments (a walk that found nothing would pass).
    for needed in [
        "kdray build input",
        "kdray build out",
        "kdray info file",
        "kdray merge out",
        "kdray rays input",
        "kdray rays out",
        "kdray rays seed",
        "kdray rays kind",
        "kdray hits file",
        "kdray trace out",
    ] {
        assert!(texts.iter().any(|(p, _)| p == needed), "{needed} not found");
    }
    let missing: Vec<&str> = texts
        .iter()
        .filter(|(_, h)| h.as_deref().is_none_or(|h| h.trim().is_empty()))
        .map(|(p, _)| p.as_str())
        .collect();
    assert!(missing.is_empty(), "no help text: {missing:?}");
}

/// Documents kept outside the repository are caught in every file, help text's sources included,
/// by `scripts/doc-refs.py`.
#[test]
fn help_names_nothing_outside_the_repository() {
    for (path, help) in help_texts() {
        let help = help.unwrap_or_default();
        for word in ["shared/", "seed §", "seed's", "extension of the contract"] {
            assert!(!help.contains(word), "{path}: help names `{word}`: {help}");
        }
    }
}
