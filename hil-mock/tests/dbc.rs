//! `docs/wire.dbc` is generated from the codec's constants: this test fails when the file and
//! the wire format disagree. Regenerate with `UPDATE_DBC=1 cargo test -p hil-mock --test dbc`.

use hil_mock::wire::{Source, AGENT_ID_BASE, LEADER_ID, MAX_AGENT, PAYLOAD_LEN};

/// One Q7.16 value message (leader or agent).
fn value_message(out: &mut String, id: u16, name: &str) {
    out.push_str(&format!("BO_ {id} {name}: {PAYLOAD_LEN} {name}\n"));
    out.push_str(&format!(
        " SG_ y : 0|24@1- ({},0) [-128|{}] \"\" Vector__XXX\n",
        1.0 / 65536.0,
        128.0 - 1.0 / 65536.0
    ));
    out.push_str(" SG_ seq : 24|6@1+ (1,0) [0|63] \"\" Vector__XXX\n");
    out.push_str(" SG_ saturated : 30|1@1+ (1,0) [0|1] \"\" Vector__XXX\n");
    out.push_str(" SG_ no_value : 31|1@1+ (1,0) [0|1] \"\" Vector__XXX\n\n");
}

fn expected() -> String {
    let mut s = String::from("VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: Leader");
    for i in 1..=MAX_AGENT {
        s.push_str(&format!(" Agent{i}"));
    }
    s.push_str("\n\n");
    value_message(&mut s, LEADER_ID, "Leader");
    for i in 1..=MAX_AGENT {
        let id = Source::Agent(i).raw_id().expect("agents 1..=255 have ids");
        assert_eq!(id, AGENT_ID_BASE + u16::from(i) - 1);
        value_message(&mut s, id, &format!("Agent{i}"));
    }
    s.push_str(&format!(
        "CM_ BO_ {LEADER_ID} \"Leader reference y_d, one frame per sample\";\n"
    ));
    s.push_str(&format!(
        "CM_ SG_ {LEADER_ID} y \"Q7.16 value, resolution 2^-16; 0 when no_value\";\n"
    ));
    s.push_str(&format!(
        "CM_ SG_ {LEADER_ID} seq \"sender's sample count modulo 64\";\n"
    ));
    s.push_str(&format!(
        "CM_ SG_ {LEADER_ID} saturated \"y was outside [-128, 128) and clamped\";\n"
    ));
    s.push_str(&format!(
        "CM_ SG_ {LEADER_ID} no_value \"the sender had no finite value\";\n"
    ));
    s
}

#[test]
fn wire_dbc_matches_the_codec() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/wire.dbc");
    let want = expected();
    if std::env::var_os("UPDATE_DBC").is_some() {
        std::fs::write(path, &want).expect("write docs/wire.dbc");
    }
    let have = std::fs::read_to_string(path).expect("docs/wire.dbc exists");
    assert!(
        have == want,
        "docs/wire.dbc is out of date: run UPDATE_DBC=1 cargo test -p hil-mock --test dbc"
    );
}
