//! `flexcal`: the desktop tool.
fn main() {}
