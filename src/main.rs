//! The `wavepath` binary: all the work is in `wavepath::cli`.

fn main() {
    match wavepath::cli::run() {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}
