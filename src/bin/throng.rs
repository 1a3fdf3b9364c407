//! The `throng` command-line program.

fn main() {
    println!("throng {}", env!("CARGO_PKG_VERSION"));
}
