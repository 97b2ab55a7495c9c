//! Agent-steps per second of the whole loop (controller + plant + link + metrics).
fn main() {}
