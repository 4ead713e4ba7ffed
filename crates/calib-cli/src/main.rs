//! The `calib` command (work in progress: see issue 4).
fn main() {
    eprintln!("calib: not implemented yet");
    std::process::exit(2);
}
