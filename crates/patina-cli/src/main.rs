//! `patina`: the command-line tool (see the `patina_cli` library).

use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match patina_cli::parse(std::env::args_os()) {
        Ok(c) => c,
        Err(e) if patina_cli::is_display(&e) => e.exit(),
        Err(e) => {
            eprintln!("patina: {}", patina_cli::parse_message(&e));
            return ExitCode::from(2);
        }
    };
    match patina_cli::execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("patina: {}", patina_cli::error_message(&e));
            ExitCode::from(if e.is_usage() { 2 } else { 1 })
        }
    }
}
