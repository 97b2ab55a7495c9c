//! `docs/wire.dbc` is written from the codec's description of every frame kind
//! (`agent_node::dbc`): this test fails, naming the first line that differs, when the
//! committed file and the codec disagree. `UPDATE_DBC=1 cargo test -p agent-node --test dbc`
//! rewrites it.

use agent_node::dbc::write_dbc;

#[test]
fn wire_dbc_matches_the_codec() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/wire.dbc");
    let mut want = String::new();
    write_dbc(&mut want).expect("writing into a String cannot fail");
    if std::env::var_os("UPDATE_DBC").is_some() {
        std::fs::write(path, &want).expect("write docs/wire.dbc");
    }
    let have = std::fs::read_to_string(path).expect("docs/wire.dbc exists");
    let first_difference = have
        .lines()
        .zip(want.lines())
        .enumerate()
        .find(|(_, (h, w))| h != w);
    if let Some((k, (h, w))) = first_difference {
        panic!(
            "docs/wire.dbc line {}: the file has\n  {h}\nthe codec writes\n  {w}\n\
             (rewrite it: UPDATE_DBC=1 cargo test -p agent-node --test dbc)",
            k + 1
        );
    }
    assert!(
        have == want,
        "docs/wire.dbc has {} lines, the codec writes {} (rewrite it: UPDATE_DBC=1 cargo test \
         -p agent-node --test dbc)",
        have.lines().count(),
        want.lines().count()
    );
}
