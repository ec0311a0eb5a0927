//! The `bendscope` binary: parses the command line and dispatches to the library.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    let result = match &args.command {
        cli::Command::Calibrate(a) => cli::calibrate::run(a),
        cli::Command::Scale(a) => cli::scale::run(a),
        cli::Command::Process(a) => cli::process::run(a),
        cli::Command::Simulate(a) => cli::simulate::run(a),
        cli::Command::Render(a) => cli::render::run(a),
        cli::Command::Compare(a) => cli::compare::run(a),
        cli::Command::Study(a) => cli::study::run(a),
        cli::Command::Control(a) => cli::control::run(a),
        cli::Command::Demo(a) => cli::demo::run(a),
        cli::Command::Sweep(a) => cli::sweep::run(a),
        cli::Command::Surrogate(a) => cli::surrogate::run(a),
        cli::Command::Optimize(a) => cli::optimize::run(a),
        cli::Command::Acquire(a) => cli::acquire::run(a),
        cli::Command::Material(a) => cli::material::run(a),
        cli::Command::FitModel(a) => cli::fit_model::run(a),
        cli::Command::Inspect(a) => cli::inspect::run(a),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            // One line: the error and those of its causes it does not say already.
            let mut msg = format!("error: {e}");
            for cause in e.chain().skip(1) {
                let text = cause.to_string();
                if !msg.contains(&text) {
                    msg.push_str(&format!(": {text}"));
                }
            }
            eprintln!("{msg}");
            let full = e.chain().any(bendscope::io::is_storage_full);
            ExitCode::from(if full {
                cli::EXIT_NO_SPACE
            } else {
                cli::EXIT_BAD_INPUT
            })
        }
    }
}
