//! `hapticgen-fw-reference`: the host side of `scripts/firmware.sh`.
//!
//! ```text
//! hapticgen-fw-reference list                       image names, one per line
//! hapticgen-fw-reference run <image> <f32|f64>      the scenario on the host (same output format)
//! hapticgen-fw-reference size <elf>                 flash and static RAM of an image
//! hapticgen-fw-reference push <image>               the operator's push (N) of a `wall_contact` image
//! hapticgen-fw-reference check <image> <qemu-output> <elf> [--limits=warn]
//! hapticgen-fw-reference check-other-model <image> <qemu-output> <elf> [--limits=warn]
//! hapticgen-fw-reference panics <probe-elf>         the panic paths left in a control-path probe
//! hapticgen-fw-reference generated                  the directory of pre-generated images
//! hapticgen-fw-reference link-stream <uart> <qemu-output>   the link-cost image's UART frames
//! ```
//!
//! `check` compares the QEMU run with the host runs of the same scenario and enforces the
//! limits; it prints one result row and exits non-zero, naming every violation, on failure.
//! `check-other-model` does the same for an image built from another model file than its
//! line's (`HAPTICGEN_FW_MODEL`): the checks that hold for any model of the line's shape, and
//! the limits (`check_other_model`).
//! `panics` exits non-zero, naming the panic symbols, when a control-path probe (see
//! `hapticgen_fw_control::probe`) still holds a panic path.

use std::process::ExitCode;

use hapticgen_fw_reference::{
    check, check_other_model, elf, link_stream, panics, variants, Stdout, GENERATED_IMAGES,
};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match args.as_slice() {
        ["push", name] => match variants::wall_push(name) {
            Some(f) => {
                println!("{f}");
                ExitCode::SUCCESS
            }
            None => ExitCode::FAILURE,
        },
        ["generated"] => {
            println!("{GENERATED_IMAGES}");
            ExitCode::SUCCESS
        }
        ["list"] => {
            for (name, _) in variants::VARIANTS {
                println!("{name}");
            }
            ExitCode::SUCCESS
        }
        ["run", name, scalar] => match variants::run(name, scalar, &mut Stdout) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        ["size", path] => match elf::sizes(path) {
            Ok(s) => {
                println!("text={} data={} bss={} flash={} ram={}", s.text, s.data, s.bss, s.flash(), s.ram());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {path}: {e}");
                ExitCode::FAILURE
            }
        },
        ["panics", path] => match panics::panic_symbols(path) {
            Ok(found) if found.is_empty() => {
                println!("no panic path in {path}");
                ExitCode::SUCCESS
            }
            Ok(found) => {
                for symbol in found {
                    eprintln!("FAIL {path}: panic path left: {symbol}");
                }
                ExitCode::FAILURE
            }
            Err(e) => {
                eprintln!("error: {path}: {e}");
                ExitCode::FAILURE
            }
        },
        ["check", name, output, elf_path, rest @ ..] if rest.is_empty() || rest == ["--limits=warn"] => {
            verdict(check(name, output, elf_path, !rest.is_empty()))
        }
        ["check-other-model", name, output, elf_path, rest @ ..]
            if rest.is_empty() || rest == ["--limits=warn"] =>
        {
            verdict(check_other_model(name, output, elf_path, !rest.is_empty()))
        }
        ["link-stream", uart, output] => {
            let read = std::fs::read(uart).map_err(|e| format!("{uart}: {e}"));
            let text = std::fs::read_to_string(output).map_err(|e| format!("{output}: {e}"));
            match (read, text) {
                (Ok(bytes), Ok(text)) => match link_stream::check(&bytes, &text) {
                    Ok(shapes) => {
                        for (joints, task, frames) in shapes {
                            println!("link stream: {frames} state frames of {joints} joints, {task} axes, all valid");
                        }
                        ExitCode::SUCCESS
                    }
                    Err(errors) => {
                        for e in errors {
                            eprintln!("FAIL {uart}: {e}");
                        }
                        ExitCode::FAILURE
                    }
                },
                (Err(e), _) | (_, Err(e)) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        _ => {
            eprintln!("usage: hapticgen-fw-reference list | run <image> <f32|f64> | size <elf> | push <image> | check <image> <qemu-output> <elf> [--limits=warn] | check-other-model <image> <qemu-output> <elf> [--limits=warn] | panics <probe-elf> | generated | link-stream <uart> <qemu-output>");
            ExitCode::from(2)
        }
    }
}

/// A check's exit status: success, or a `FAIL …` line per error and failure.
fn verdict(checked: Result<(), Vec<String>>) -> ExitCode {
    match checked {
        Ok(()) => ExitCode::SUCCESS,
        Err(errors) => {
            for e in errors {
                eprintln!("FAIL {e}");
            }
            ExitCode::FAILURE
        }
    }
}
