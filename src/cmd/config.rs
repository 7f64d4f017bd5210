//! `--config FILE.toml` and `--rtklib-conf FILE.conf`: a command's options from files.
//!
//! The files are expanded into the flags they stand for before clap parses the command line,
//! so a file holds exactly what the flags hold, with the same checks, defaults and help
//! texts, and a flag on the command line wins over both files (the TOML file wins over the
//! RTKLIB one). A list-valued flag given on the command line replaces the file's list.

use clap::{ArgAction, Command};
use integration::rtklib_conf::{self, resolve, Setting};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The commands that take option files.
const COMMANDS: [&str; 3] = ["ppk", "exposures", "ins"];

/// Flags a file may not set.
const NOT_IN_FILES: [&str; 4] = ["config", "rtklib-conf", "help", "version"];

/// The argument list to parse, and notes on what the files set.
pub struct Expanded {
    /// The command line with the files' flags inserted after the command name.
    pub args: Vec<OsString>,
    /// What each file set and what it could not (printed unless `--quiet`).
    pub notes: Vec<String>,
}

/// A file that could not be used: the message names it (and the line, where it applies).
#[derive(Debug)]
pub struct ConfigError(pub String);

impl ConfigError {
    /// The exit code: 1 when the file cannot be read, 2 (bad usage) for what it holds.
    pub fn exit_code(&self) -> i32 {
        if self.0.starts_with("cannot read") {
            1
        } else {
            2
        }
    }
}

/// Expand the option files named on `argv` (the process's arguments, program name first)
/// for the command `cli` describes; `argv` unchanged when there are none.
pub fn expand(cli: &Command, argv: Vec<OsString>) -> Result<Expanded, ConfigError> {
    let unchanged = |argv| Expanded {
        args: argv,
        notes: Vec::new(),
    };
    let Some(at) = command_position(&argv) else {
        return Ok(unchanged(argv));
    };
    let name = argv[at].to_string_lossy().to_string();
    let Some(sub) = cli
        .get_subcommands()
        .find(|s| s.get_name() == name && COMMANDS.contains(&s.get_name()))
    else {
        return Ok(unchanged(argv));
    };
    let rest = &argv[at + 1..];
    let toml_file = flag_value(rest, "config");
    let conf_file = flag_value(rest, "rtklib-conf");
    if toml_file.is_none() && conf_file.is_none() {
        return Ok(unchanged(argv));
    }
    let mut notes = Vec::new();
    let mut settings: Vec<Setting> = Vec::new();
    if let Some(f) = &conf_file {
        let text = read(f)?;
        let mapped = rtklib_conf::map(&text, f.parent().unwrap_or(Path::new("")));
        notes.extend(mapped.notes(f));
        settings = mapped.settings;
    }
    if let Some(f) = &toml_file {
        for s in from_toml(sub, f, &read(f)?)? {
            settings.retain(|o| o.flag != s.flag);
            settings.push(s);
        }
    }
    let mut args: Vec<OsString> = argv[..=at].to_vec();
    for s in &settings {
        let arg = sub
            .get_arguments()
            .find(|a| a.get_long() == Some(s.flag.as_str()))
            .ok_or_else(|| ConfigError(format!("internal: no flag --{}", s.flag)))?;
        if given(rest, arg) {
            continue;
        }
        args.extend(tokens(arg, s));
    }
    args.extend(rest.iter().cloned());
    Ok(Expanded { args, notes })
}

/// Index of the command name in `argv`: the first word that is neither an option nor the
/// value of `--threads`.
fn command_position(argv: &[OsString]) -> Option<usize> {
    let mut i = 1;
    while i < argv.len() {
        let t = argv[i].to_string_lossy();
        if t == "--threads" {
            i += 2;
            continue;
        }
        if !t.starts_with('-') {
            return Some(i);
        }
        i += 1;
    }
    None
}

/// The value of `--NAME VALUE` or `--NAME=VALUE` among `args`.
fn flag_value(args: &[OsString], name: &str) -> Option<PathBuf> {
    let long = format!("--{name}");
    let eq = format!("--{name}=");
    for (i, a) in args.iter().enumerate() {
        let t = a.to_string_lossy();
        if t == long {
            return args.get(i + 1).map(PathBuf::from);
        }
        if let Some(v) = t.strip_prefix(&eq) {
            return Some(PathBuf::from(v));
        }
    }
    None
}

/// Whether the command line gives the flag `arg` itself (long or short form).
fn given(args: &[OsString], arg: &clap::Arg) -> bool {
    let long = arg.get_long().map(|l| format!("--{l}"));
    let short = arg.get_short().map(|c| format!("-{c}"));
    args.iter().map(|a| a.to_string_lossy()).any(|t| {
        long.as_ref()
            .is_some_and(|l| t == *l || t.starts_with(&format!("{l}=")))
            || short.as_ref().is_some_and(|s| t.starts_with(s.as_str()))
    })
}

/// The tokens that set `s` on the command line.
fn tokens(arg: &clap::Arg, s: &Setting) -> Vec<OsString> {
    let flag = format!("--{}", s.flag);
    if matches!(arg.get_action(), ArgAction::SetTrue) {
        return if s.values.iter().any(|v| v == "true") {
            vec![OsString::from(flag)]
        } else {
            Vec::new()
        };
    }
    s.values
        .iter()
        .map(|v| OsString::from(format!("{flag}={v}")))
        .collect()
}

/// Read an options file as text.
fn read(path: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(path).map_err(|e| {
        ConfigError(format!(
            "cannot read the options file {}: {e}",
            path.display()
        ))
    })
}

/// The settings of a TOML options file for the command `sub`; relative paths are taken from
/// the file's folder.
pub fn from_toml(sub: &Command, path: &Path, text: &str) -> Result<Vec<Setting>, ConfigError> {
    let table: toml::Table = toml::from_str(text).map_err(|e| {
        let at = e.span().map_or(0, |s| s.start).min(text.len());
        let line = text[..at].matches('\n').count() + 1;
        let message = e.message().trim().replace('\n', " ");
        ConfigError(format!("{} line {line}: {message}", path.display()))
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for (key, value) in &table {
        let flag = key.replace('_', "-");
        let arg = sub
            .get_arguments()
            .find(|a| a.get_long() == Some(flag.as_str()))
            .filter(|_| !NOT_IN_FILES.contains(&flag.as_str()))
            .ok_or_else(|| unknown_key(sub, path, key))?;
        let values = toml_values(arg, value, dir).ok_or_else(|| {
            ConfigError(format!(
                "{}: option '{key}' has a value of the wrong kind ({value}); \
                 see `ppkat {} --help` for --{flag}",
                path.display(),
                sub.get_name()
            ))
        })?;
        out.push(Setting { flag, values });
    }
    Ok(out)
}

/// The error for a key that is no flag of the command, listing the keys there are.
fn unknown_key(sub: &Command, path: &Path, key: &str) -> ConfigError {
    let keys: Vec<&str> = sub
        .get_arguments()
        .filter_map(|a| a.get_long())
        .filter(|l| !NOT_IN_FILES.contains(l))
        .collect();
    ConfigError(format!(
        "{}: unknown option '{key}'; the options of `ppkat {}` are: {}",
        path.display(),
        sub.get_name(),
        keys.join(", ")
    ))
}

/// A TOML value as the flag's values: strings, numbers and booleans as written, an array as
/// one value per element for a list flag, else joined by commas (`base-pos = [x, y, z]`).
fn toml_values(arg: &clap::Arg, value: &toml::Value, dir: &Path) -> Option<Vec<String>> {
    let is_path = arg.get_value_parser().type_id() == std::any::TypeId::of::<PathBuf>();
    let scalar = |v: &toml::Value| -> Option<String> {
        match v {
            toml::Value::String(s) if is_path => Some(resolve(dir, s)),
            toml::Value::String(s) if s.starts_with("geoid:") => {
                Some(format!("geoid:{}", resolve(dir, &s["geoid:".len()..])))
            }
            toml::Value::String(s) => Some(s.clone()),
            toml::Value::Integer(i) => Some(i.to_string()),
            toml::Value::Float(f) if f.is_finite() => Some(f.to_string()),
            toml::Value::Boolean(b) => Some(b.to_string()),
            _ => None,
        }
    };
    match (value, arg.get_action()) {
        (toml::Value::Boolean(_), ArgAction::SetTrue) => scalar(value).map(|v| vec![v]),
        (_, ArgAction::SetTrue) => None,
        (toml::Value::Array(a), ArgAction::Append) => a.iter().map(scalar).collect(),
        (toml::Value::Array(a), _) => {
            let parts: Option<Vec<String>> = a.iter().map(scalar).collect();
            parts.map(|p| vec![p.join(",")])
        }
        (v, _) => scalar(v).map(|v| vec![v]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cli() -> Command {
        Command::new("ppkat").subcommand(
            Command::new("ppk")
                .arg(
                    clap::Arg::new("rover")
                        .long("rover")
                        .value_parser(clap::value_parser!(PathBuf)),
                )
                .arg(
                    clap::Arg::new("nav")
                        .long("nav")
                        .action(ArgAction::Append)
                        .value_parser(clap::value_parser!(PathBuf)),
                )
                .arg(clap::Arg::new("elev_mask").long("elev-mask"))
                .arg(clap::Arg::new("base_pos").long("base-pos"))
                .arg(
                    clap::Arg::new("static")
                        .long("base-from-ppp")
                        .action(ArgAction::SetTrue),
                )
                .arg(
                    clap::Arg::new("out")
                        .long("out")
                        .short('o')
                        .value_parser(clap::value_parser!(PathBuf)),
                )
                .arg(
                    clap::Arg::new("config")
                        .long("config")
                        .value_parser(clap::value_parser!(PathBuf)),
                ),
        )
    }

    fn os(v: &[&str]) -> Vec<OsString> {
        v.iter().map(OsString::from).collect()
    }

    #[test]
    fn toml_keys_become_flags_and_the_command_line_wins() {
        let dir = testkit::scratch_dir("config");
        let f = dir.join("flight.toml");
        std::fs::write(
            &f,
            "rover = \"r.obs\"\nnav = [\"a.nav\", \"/abs/b.nav\"]\nelev_mask = 15\n\
             base-pos = [-3978241.958, 3382840.234, 3649900.853]\nbase-from-ppp = true\n\
             out = \"x.pos\"\n",
        )
        .unwrap();
        let argv = os(&[
            "ppkat",
            "--threads",
            "2",
            "ppk",
            "--config",
            f.to_str().unwrap(),
            "-o",
            "y.pos",
        ]);
        let e = expand(&cli(), argv).unwrap();
        let got: Vec<String> = e
            .args
            .iter()
            .map(|a| a.to_string_lossy().to_string())
            .collect();
        let d = dir.to_string_lossy();
        assert_eq!(
            got,
            vec![
                "ppkat".to_string(),
                "--threads".into(),
                "2".into(),
                "ppk".into(),
                "--base-from-ppp".into(),
                "--base-pos=-3978241.958,3382840.234,3649900.853".into(),
                "--elev-mask=15".into(),
                format!("--nav={d}/a.nav"),
                "--nav=/abs/b.nav".into(),
                format!("--rover={d}/r.obs"),
                "--config".into(),
                f.to_string_lossy().to_string(),
                "-o".into(),
                "y.pos".into(),
            ]
        );
    }

    #[test]
    fn unknown_keys_and_wrong_kinds_are_errors_naming_the_file() {
        let sub = cli().find_subcommand("ppk").unwrap().clone();
        let p = Path::new("f.toml");
        let e = from_toml(&sub, p, "elev-mak = 15").unwrap_err().0;
        assert!(
            e.contains("f.toml") && e.contains("'elev-mak'") && e.contains("elev-mask"),
            "{e}"
        );
        let e = from_toml(&sub, p, "base-from-ppp = \"yes\"").unwrap_err().0;
        assert!(e.contains("wrong kind"), "{e}");
        let e = from_toml(&sub, p, "config = \"x\"").unwrap_err().0;
        assert!(e.contains("unknown option 'config'"), "{e}");
        let e = from_toml(&sub, p, "rover = ").unwrap_err().0;
        assert!(e.contains("f.toml") && e.contains("line 1"), "{e}");
    }

    #[test]
    fn other_commands_and_lines_without_files_are_unchanged() {
        for v in [
            &["ppkat", "spp", "--config", "x"][..],
            &["ppkat", "ppk", "--rover", "r"],
        ] {
            let e = expand(&cli(), os(v)).unwrap();
            assert_eq!(e.args, os(v));
        }
    }
}
