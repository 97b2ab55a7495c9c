//! `docs/wire.dbc` is generated from the codec's constants: this test fails when the file and
//! the wire format disagree. Regenerate with `UPDATE_DBC=1 cargo test -p agent-node --test dbc`.

use agent_node::{
    link::io,
    wire::{Source, AGENT_ID_BASE, LEADER_ID, MAX_AGENT, PAYLOAD_LEN},
};

/// A DBC message id of a 29-bit identifier (bit 31 set).
const EXTENDED: u32 = 0x8000_0000;

/// Process-I/O messages of the PIL link (29-bit ids): name, id, sender, signals as
/// (name, start bit, length, kind) with kind `f` IEEE `f32`, `u` unsigned, in little-endian
/// order.
type Signal = (&'static str, u32, u32, char);
const IO_MESSAGES: &[(&str, u32, &str, &[Signal])] = &[
    (
        "Sync",
        io::SYNC,
        "Host",
        &[
            ("x1", 0, 32, 'f'),
            ("x2", 32, 32, 'f'),
            ("dt_us", 64, 32, 'u'),
        ],
    ),
    ("Clock", io::CLOCK, "Host", &[("t_us", 0, 32, 'u')]),
    (
        "Report",
        io::REPORT,
        "Node",
        &[
            ("q1", 0, 32, 'f'),
            ("q2", 32, 32, 'f'),
            ("u1", 64, 32, 'f'),
            ("u2", 96, 32, 'f'),
            ("e1", 128, 32, 'f'),
            ("e2", 160, 32, 'f'),
            ("mu", 192, 32, 'f'),
            ("xi", 224, 32, 'f'),
            ("lambda", 256, 32, 'f'),
            ("fault", 288, 8, 'u'),
            ("stale", 296, 8, 'u'),
            ("missing", 304, 8, 'u'),
            ("leader_stale", 312, 1, 'u'),
            ("leader_missing", 313, 1, 'u'),
            ("instructions", 320, 32, 'u'),
            ("resolution", 352, 32, 'u'),
        ],
    ),
    (
        "Stats",
        io::STATS,
        "Node",
        &[("stack_bytes", 0, 32, 'u'), ("malformed", 32, 32, 'u')],
    ),
];

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
    let mut s = String::from("VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: Host Node Leader");
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
    for (name, id, sender, signals) in IO_MESSAGES {
        let bytes = signals
            .iter()
            .map(|(_, st, l, _)| (st + l).div_ceil(8))
            .max();
        s.push_str(&format!(
            "BO_ {} {name}: {} {sender}\n",
            id | EXTENDED,
            bytes.unwrap_or(0)
        ));
        for (sig, start, len, kind) in *signals {
            let sign = if *kind == 'f' { '-' } else { '+' };
            s.push_str(&format!(
                " SG_ {sig} : {start}|{len}@1{sign} (1,0) [0|0] \"\" Vector__XXX\n"
            ));
        }
        s.push('\n');
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
    s.push_str(&format!(
        "CM_ BO_ {} \"PIL link only (docs/NETWORK.md 9): payload of the k (tick) record, base64 on the link, not a CAN frame; dt_us only when the interval changed (8 bytes otherwise)\";\n",
        io::SYNC | EXTENDED
    ));
    s.push_str(&format!(
        "CM_ BO_ {} \"PIL link only (docs/NETWORK.md 9): payload of the y (report) record, base64 on the link, not a CAN frame\";\n",
        io::REPORT | EXTENDED
    ));
    for (_, id, _, signals) in IO_MESSAGES {
        for (sig, _, _, kind) in *signals {
            if *kind == 'f' {
                s.push_str(&format!("SIG_VALTYPE_ {} {sig} : 1;\n", id | EXTENDED));
            }
        }
    }
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
        "docs/wire.dbc is out of date: run UPDATE_DBC=1 cargo test -p agent-node --test dbc"
    );
}
