//! Frame layouts byte by byte (CiA 301), refusals that leave the value unchanged.

use super::od::{ParamStore, OBJECTS, PARAM_BASE, SETTING_BASE};
use super::*;
use crate::node::NodeConfig;
use crate::wire::{IdPlan, Source};
use controller_core::{ControllerConfig, Param};

const ID: u8 = 3;

fn device() -> Device<2> {
    let node = NodeConfig::new(ID, [1, 2, 0, 0], 2_500);
    let ctrl = ControllerConfig::<2> {
        neighbour_count: 2,
        pinned: false,
        ..ControllerConfig::default()
    };
    let store = ParamStore::new(node.identity(), &ctrl).expect("representable");
    let mut d = Device::new(store, Identity::default(), false);
    d.boot(0);
    d
}

fn frames(d: &mut Device<2>) -> Vec<(u16, Vec<u8>)> {
    core::iter::from_fn(|| d.next_tx())
        .map(|f| (f.id, f.data().to_vec()))
        .collect()
}

fn events(d: &mut Device<2>) -> Vec<Event> {
    core::iter::from_fn(|| d.next_event()).collect()
}

fn param_index(p: Param) -> u16 {
    PARAM_BASE + Param::ALL.iter().position(|q| *q == p).expect("listed") as u16
}

/// One SDO request, its one response.
fn sdo(d: &mut Device<2>, req: [u8; 8]) -> [u8; 8] {
    assert!(d.on_frame(sdo_rx_id(ID), &req, 10));
    let f = frames(d);
    assert_eq!(f.len(), 1, "{f:x?}");
    assert_eq!(f[0].0, 0x583);
    f[0].1.clone().try_into().expect("8 bytes")
}

fn download(d: &mut Device<2>, index: u16, sub: u8, v: &[u8]) -> [u8; 8] {
    let i = index.to_le_bytes();
    let mut req = [
        0x23 | (((4 - v.len()) as u8) << 2),
        i[0],
        i[1],
        sub,
        0,
        0,
        0,
        0,
    ];
    req[4..4 + v.len()].copy_from_slice(v);
    sdo(d, req)
}

fn upload(d: &mut Device<2>, index: u16, sub: u8) -> [u8; 8] {
    let i = index.to_le_bytes();
    sdo(d, [0x40, i[0], i[1], sub, 0, 0, 0, 0])
}

#[test]
fn boot_up_then_pre_operational_heartbeat() {
    let mut d = device();
    assert_eq!(frames(&mut d), vec![(0x703, vec![0x00])]);
    assert_eq!(d.nmt(), NmtState::PreOperational);
    assert_eq!(events(&mut d), vec![Event::Nmt(NmtState::PreOperational)]);
    // 0x1017 = 100 ms over SDO: the heartbeat follows at once, then every 100 ms.
    assert_eq!(
        download(&mut d, 0x1017, 0, &100u16.to_le_bytes()),
        [0x60, 0x17, 0x10, 0, 0, 0, 0, 0]
    );
    d.tick(1_000);
    d.tick(50_000);
    d.tick(101_000);
    assert_eq!(
        frames(&mut d),
        vec![(0x703, vec![0x7F]), (0x703, vec![0x7F])]
    );
    assert!(!d.outputs_enabled());
}

#[test]
fn nmt_start_stop_pre_operational_and_addressing() {
    let mut d = device();
    frames(&mut d);
    events(&mut d);
    d.set_heartbeat_ms(10);
    // Addressed to node 4: ignored.
    d.on_frame(NMT_ID, &[0x01, 4], 0);
    assert_eq!(d.nmt(), NmtState::PreOperational);
    d.on_frame(NMT_ID, &[0x01, ID], 0);
    assert_eq!(d.nmt(), NmtState::Operational);
    assert!(d.outputs_enabled());
    d.tick(0);
    assert_eq!(frames(&mut d), vec![(0x703, vec![0x05])]);
    // Broadcast stop: no SDO answer in stopped, heartbeat 0x04.
    d.on_frame(NMT_ID, &[0x02, 0], 0);
    assert_eq!(d.nmt(), NmtState::Stopped);
    d.on_frame(sdo_rx_id(ID), &[0x40, 0, 0x10, 0, 0, 0, 0, 0], 1);
    d.tick(10_000);
    assert_eq!(frames(&mut d), vec![(0x703, vec![0x04])]);
    d.on_frame(NMT_ID, &[0x80, ID], 0);
    assert_eq!(d.nmt(), NmtState::PreOperational);
    assert_eq!(
        events(&mut d),
        vec![
            Event::Nmt(NmtState::Operational),
            Event::Nmt(NmtState::Stopped),
            Event::Nmt(NmtState::PreOperational)
        ]
    );
}

#[test]
fn reset_communication_applies_a_written_node_id() {
    let mut d = device();
    frames(&mut d);
    assert_eq!(download(&mut d, SETTING_BASE, 0, &[9])[0], 0x60);
    assert_eq!(d.node_id(), ID, "applied only at reset");
    frames(&mut d);
    d.on_frame(NMT_ID, &[0x82, ID], 0);
    assert_eq!(d.node_id(), 9);
    assert_eq!(frames(&mut d), vec![(0x709, vec![0x00])]);
    // Node 3 no longer answers; node 9 does, and refuses node-ID 128.
    assert!(!d.on_frame(0x603, &[0x40, 0, 0x10, 0, 0, 0, 0, 0], 1));
    d.on_frame(0x609, &[0x2F, 0x00, 0x21, 0, 128, 0, 0, 0], 1);
    assert_eq!(
        frames(&mut d),
        vec![(0x589, vec![0x80, 0x00, 0x21, 0, 0x30, 0x00, 0x09, 0x06])]
    );
}

#[test]
fn expedited_upload_of_device_type_and_identity() {
    let mut d = device();
    frames(&mut d);
    assert_eq!(upload(&mut d, 0x1000, 0), [0x43, 0x00, 0x10, 0, 0, 0, 0, 0]);
    assert_eq!(upload(&mut d, 0x1018, 0), [0x4F, 0x18, 0x10, 0, 4, 0, 0, 0]);
    assert_eq!(
        upload(&mut d, 0x1014, 0),
        [0x43, 0x14, 0x10, 0, 0x83, 0, 0, 0]
    );
    // Missing object and sub-index.
    assert_eq!(
        upload(&mut d, 0x1234, 0),
        [0x80, 0x34, 0x12, 0, 0x00, 0x00, 0x02, 0x06]
    );
    assert_eq!(
        upload(&mut d, 0x1000, 1),
        [0x80, 0x00, 0x10, 1, 0x11, 0x00, 0x09, 0x06]
    );
    // Read-only.
    assert_eq!(
        download(&mut d, 0x1000, 0, &[1, 0, 0, 0]),
        [0x80, 0x00, 0x10, 0, 0x02, 0x00, 0x01, 0x06]
    );
}

#[test]
fn a_refused_write_aborts_with_the_range_code_and_leaves_the_value() {
    let mut d = device();
    frames(&mut d);
    let zeta = param_index(Param::Zeta);
    let i = zeta.to_le_bytes();
    let before = upload(&mut d, zeta, 0);
    assert_eq!(&before[4..8], &0.1f32.to_le_bytes());
    // ζ = 1.5 is outside (0, 1): 0x0609_0030.
    assert_eq!(
        download(&mut d, zeta, 0, &1.5f32.to_le_bytes()),
        [0x80, i[0], i[1], 0, 0x30, 0x00, 0x09, 0x06]
    );
    assert_eq!(upload(&mut d, zeta, 0), before);
    // A value in range is taken.
    assert_eq!(
        download(&mut d, zeta, 0, &0.2f32.to_le_bytes()),
        [0x60, i[0], i[1], 0, 0, 0, 0, 0]
    );
    assert_eq!(&upload(&mut d, zeta, 0)[4..8], &0.2f32.to_le_bytes());
    // φ_up below φ_low of step 2: too low for φ_up (`AtLeast`), via the constructor.
    let phi_low = param_index(Param::PhiLow);
    let r = download(&mut d, phi_low, 2, &5.0f32.to_le_bytes());
    assert_eq!(&r[4..8], &0x0609_0031u32.to_le_bytes(), "{r:x?}");
    assert_eq!(&upload(&mut d, phi_low, 2)[4..8], &1.0f32.to_le_bytes());
    // A baseline parameter with the predefined-time scheme: incompatible.
    let kappa = param_index(Param::Kappa);
    let r = download(&mut d, kappa, 0, &2.0f32.to_le_bytes());
    assert_eq!(&r[4..8], &0x0604_0043u32.to_le_bytes());
    // A name by position beyond the list.
    let r = download(&mut d, param_index(Param::Scheme), 0, &[2]);
    assert_eq!(&r[4..8], &0x0609_0030u32.to_le_bytes());
    // Wrong length.
    let r = download(&mut d, zeta, 0, &[1, 2]);
    assert_eq!(&r[4..8], &0x0607_0013u32.to_le_bytes());
}

#[test]
fn manufacturer_writes_only_in_pre_operational() {
    let mut d = device();
    d.on_frame(NMT_ID, &[0x01, ID], 0);
    frames(&mut d);
    let zeta = param_index(Param::Zeta);
    let r = download(&mut d, zeta, 0, &0.2f32.to_le_bytes());
    assert_eq!(&r[4..8], &0x0800_0022u32.to_le_bytes());
    assert_eq!(&upload(&mut d, zeta, 0)[4..8], &0.1f32.to_le_bytes());
    // Reads work in operational.
    assert_eq!(upload(&mut d, 0x1001, 0)[0], 0x4F);
}

#[test]
fn segmented_upload_of_the_device_name() {
    let mut d = device();
    frames(&mut d);
    assert_eq!(
        upload(&mut d, 0x1008, 0),
        [0x41, 0x08, 0x10, 0, 10, 0, 0, 0]
    );
    assert_eq!(
        sdo(&mut d, [0x60, 0, 0, 0, 0, 0, 0, 0]),
        [0x00, b'a', b'g', b'e', b'n', b't', b'-', b'n']
    );
    // Toggle 1, 4 bytes unused, last.
    assert_eq!(
        sdo(&mut d, [0x70, 0, 0, 0, 0, 0, 0, 0]),
        [0x19, b'o', b'd', b'e', 0, 0, 0, 0]
    );
    // No transfer in progress now.
    assert_eq!(sdo(&mut d, [0x60, 0, 0, 0, 0, 0, 0, 0])[0], 0x80);
}

#[test]
fn segmented_download_and_toggle_error() {
    let mut d = device();
    frames(&mut d);
    let ts = param_index(Param::Ts);
    let i = ts.to_le_bytes();
    let v = 3.0f32.to_le_bytes();
    assert_eq!(
        sdo(&mut d, [0x21, i[0], i[1], 0, 4, 0, 0, 0]),
        [0x60, i[0], i[1], 0, 0, 0, 0, 0]
    );
    // Toggle 0, 3 bytes unused, last.
    assert_eq!(
        sdo(&mut d, [0x07, v[0], v[1], v[2], v[3], 0, 0, 0]),
        [0x20, 0, 0, 0, 0, 0, 0, 0]
    );
    assert_eq!(&upload(&mut d, ts, 0)[4..8], &v);
    // A segment with the wrong toggle: 0x0503_0000, value unchanged.
    sdo(&mut d, [0x21, i[0], i[1], 0, 4, 0, 0, 0]);
    let r = sdo(&mut d, [0x17, 0, 0, 0x80, 0x40, 0, 0, 0]);
    assert_eq!(r, [0x80, i[0], i[1], 0, 0x00, 0x00, 0x03, 0x05]);
    assert_eq!(&upload(&mut d, ts, 0)[4..8], &v);
    // A transfer left hanging times out.
    sdo(&mut d, [0x21, i[0], i[1], 0, 4, 0, 0, 0]);
    d.tick(10 + SDO_TIMEOUT_US + 1);
    assert_eq!(
        frames(&mut d),
        vec![(0x583, vec![0x80, i[0], i[1], 0, 0x00, 0x00, 0x04, 0x05])]
    );
}

#[test]
fn emcy_error_register_and_error_field() {
    let mut d = device();
    frames(&mut d);
    d.report(Fault::SafeState(0b001), 0);
    assert_eq!(
        frames(&mut d),
        vec![(0x083, vec![0x50, 0x82, 0x11, 1, 0b001, 0, 0, 0])]
    );
    assert_eq!(d.error_register(), 0x11);
    assert_eq!(
        upload(&mut d, 0x1001, 0),
        [0x4F, 0x01, 0x10, 0, 0x11, 0, 0, 0]
    );
    // Reported once while active.
    d.report(Fault::SafeState(0b001), 0);
    assert!(frames(&mut d).is_empty());
    d.report(Fault::Overrun, 7);
    assert_eq!(
        frames(&mut d),
        vec![(0x083, vec![0x00, 0x62, 0x91, 4, 0, 7, 0, 0])]
    );
    assert_eq!(upload(&mut d, 0x1003, 0), [0x4F, 0x03, 0x10, 0, 2, 0, 0, 0]);
    assert_eq!(upload(&mut d, 0x1003, 1)[4..8], 0x6200u32.to_le_bytes());
    assert_eq!(upload(&mut d, 0x1003, 2)[4..8], 0x8250u32.to_le_bytes());
    d.clear(Fault::SafeState(0));
    assert_eq!(frames(&mut d), vec![(0x083, vec![0; 8])]);
    assert_eq!(d.error_register(), 0);
    // Writing 0 to sub-index 0 clears the history; anything else is refused.
    assert_eq!(download(&mut d, 0x1003, 0, &[1])[0], 0x80);
    assert_eq!(download(&mut d, 0x1003, 0, &[0])[0], 0x60);
    assert_eq!(upload(&mut d, 0x1003, 0)[4], 0);
    // Sensor loss: 0x7300; not sent while stopped (but recorded).
    d.on_frame(NMT_ID, &[0x02, ID], 0);
    d.report(Fault::SafeState(0b100), 0);
    assert!(frames(&mut d).is_empty());
    assert_eq!(d.error_register(), 0x81);
}

#[test]
fn heartbeat_consumer_loses_and_regains_a_node() {
    let mut d = device();
    d.set_consumer(1, 5, 100).expect("entry 1");
    assert_eq!(d.set_consumer(2, 5, 50), Err(Abort::ParamIncompatible));
    frames(&mut d);
    events(&mut d);
    d.on_frame(0x705, &[0x05], 1_000);
    assert_eq!(d.consumed_state(5), Some(NmtState::Operational));
    d.tick(100_000);
    assert!(events(&mut d).is_empty());
    d.tick(101_001);
    assert_eq!(events(&mut d), vec![Event::HeartbeatLost(5)]);
    assert_eq!(
        frames(&mut d),
        vec![(0x083, vec![0x30, 0x81, 0x11, 9, 5, 0, 0, 0])]
    );
    d.on_frame(0x705, &[0x7F], 120_000);
    assert_eq!(events(&mut d), vec![Event::HeartbeatResumed(5)]);
    assert_eq!(frames(&mut d), vec![(0x083, vec![0; 8])]);
}

#[test]
fn every_generated_entry_reads_back_what_is_written() {
    let mut d = device();
    frames(&mut d);
    let mut checked = 0;
    for o in OBJECTS.iter() {
        let subs = match o.kind {
            od::Kind::Var => 0..=0,
            _ => 1..=d.sub_count(o),
        };
        for sub in subs {
            let v = d.read(o.index, sub).expect("readable");
            let r = d.write(o.index, sub, v.as_slice());
            match o.item {
                od::Item::Param(_) | od::Item::Setting(_) if o.access == od::Access::ReadWrite => {
                    // Writing an entry's own value back is always accepted, except an absent
                    // optional paired value (c1 alone) which the constructor refuses, and an
                    // unused entry of the graph row (0, no agent).
                    let unused =
                        o.item == od::Item::Param(Param::Neighbours) && v.as_slice() == [0];
                    if let Err(a) = r {
                        assert!(
                            a == Abort::ParamIncompatible || (unused && a == Abort::ValueTooLow),
                            "{:#06x}/{sub} {}: {a:?}",
                            o.index,
                            o.name()
                        );
                    }
                    assert_eq!(d.read(o.index, sub), Ok(v), "{:#06x}/{sub}", o.index);
                    checked += 1;
                }
                _ => {}
            }
        }
    }
    assert!(checked > 40, "{checked}");
}

#[test]
fn table_is_sorted_and_holds_every_param() {
    assert!(OBJECTS.windows(2).all(|w| w[0].index < w[1].index));
    for p in Param::ALL {
        let o = od::find(param_index(p)).expect("object");
        assert_eq!(o.name(), p.key());
    }
}

#[test]
fn store_then_load_into_a_fresh_device_and_restore_defaults() {
    let mut d = device();
    frames(&mut d);
    let zeta = param_index(Param::Zeta);
    download(&mut d, zeta, 0, &0.25f32.to_le_bytes());
    download(&mut d, 0x1017, 0, &50u16.to_le_bytes());
    events(&mut d);
    assert_eq!(
        download(&mut d, 0x1010, 1, &SAVE_SIGNATURE.to_le_bytes())[0],
        0x60
    );
    assert_eq!(events(&mut d), vec![Event::Store]);
    let mut buf = [0u8; 1024];
    let n = d.save(&mut buf).expect("fits");
    let mut fresh = device();
    frames(&mut fresh);
    events(&mut fresh);
    fresh.load(&buf[..n]).expect("loads");
    assert_eq!(&upload(&mut fresh, zeta, 0)[4..8], &0.25f32.to_le_bytes());
    assert_eq!(upload(&mut fresh, 0x1017, 0)[4], 50);
    // A corrupted copy is refused whole.
    let mut bad = buf;
    bad[0] = b'X';
    assert!(fresh.load(&bad[..n]).is_err());
    // Wrong signature, then "load": defaults back.
    assert_eq!(
        &download(&mut fresh, 0x1011, 1, &[1, 2, 3, 4])[4..8],
        &0x0800_0020u32.to_le_bytes()
    );
    assert_eq!(
        download(&mut fresh, 0x1011, 1, &LOAD_SIGNATURE.to_le_bytes())[0],
        0x60
    );
    // The defaults are the values the device was built with, not the loaded ones.
    assert_eq!(&upload(&mut fresh, zeta, 0)[4..8], &0.1f32.to_le_bytes());
    assert_eq!(events(&mut fresh), vec![Event::Restore]);
}

#[test]
fn eds_lists_every_object_with_name_and_access() {
    let d = device();
    let mut s = String::new();
    eds::write_eds(&mut s, &d, "agent-node.eds").expect("fmt");
    for o in OBJECTS.iter() {
        let head = format!("[{:04X}]\nParameterName={}\n", o.index, o.name());
        assert!(s.contains(&head), "{head}");
    }
    assert!(s.contains("[1014]\nParameterName=COB-ID EMCY\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=$NODEID+0x80\n"));
    let zeta = format!(
        "[{:04X}]\nParameterName=controller.zeta\nObjectType=0x7\nDataType=0x0008\nAccessType=rw\nDefaultValue=0.1\n",
        param_index(Param::Zeta)
    );
    assert!(s.contains(&zeta), "{zeta}");
    let a_check = format!("[{:04X}sub2]\n", param_index(Param::ACheck));
    assert!(s.contains(&a_check));
    assert!(!s.contains(&format!("[{:04X}sub3]\n", param_index(Param::ACheck))));
    // The PDOs: 17 receive, 1 transmit, mapped bit by bit; TPDO1 on the value frame's id.
    for line in ["Granularity=1\n", "NrOfRXPDO=17\n", "NrOfTXPDO=1\n"] {
        assert!(s.contains(line), "{line}");
    }
    assert!(s.contains("[1800sub1]\nParameterName=COB-ID used by PDO\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=$NODEID+0x40000101\n"));
    assert!(s.contains("[1A00sub1]\nParameterName=Mapped object\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0x22000018\n"));
    assert!(s.contains("[2200]\nParameterName=Value y (Q7.16, y = raw / 65536)\nObjectType=0x7\nDataType=0x0010\nAccessType=ro\n"));
}

#[test]
fn a_monitor_decodes_nmt_emcy_sdo_and_heartbeat() {
    assert_eq!(
        decode(0x000, &[0x01, 2]),
        Some(Message::Nmt {
            command: Some(NmtCommand::Start),
            node: 2
        })
    );
    assert_eq!(
        decode(0x082, &[0x50, 0x82, 0x11, 1, 1, 1, 0, 0]),
        Some(Message::Emcy {
            node: 2,
            code: 0x8250,
            register: 0x11,
            info: [1, 1, 1, 0, 0]
        })
    );
    assert_eq!(
        decode(0x582, &[0x80, 0x03, 0x20, 0, 0x30, 0, 0x09, 0x06]),
        Some(Message::Sdo {
            node: 2,
            request: false,
            command: 0x80,
            index: 0x2003,
            sub: 0,
            abort: Some(0x0609_0030)
        })
    );
    assert_eq!(
        decode(0x602, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]),
        Some(Message::Sdo {
            node: 2,
            request: true,
            command: 0x40,
            index: 0x1000,
            sub: 0,
            abort: None
        })
    );
    assert_eq!(
        decode(0x702, &[0x7F]),
        Some(Message::Heartbeat {
            node: 2,
            state: Some(NmtState::PreOperational)
        })
    );
    // A value frame and the project's own heartbeat are not CANopen messages.
    assert_eq!(decode(0x103, &[0; 4]), None);
    assert_eq!(decode(0x782, &[0; 8]), None);
}

fn u32_at(r: [u8; 8]) -> u32 {
    u32::from_le_bytes([r[4], r[5], r[6], r[7]])
}

/// The mapping of a PDO as a master reads it over SDO: `(index, sub-index, bits)` entries.
fn mapping_over_sdo(d: &mut Device<2>, index: u16) -> Vec<(u16, u8, u8)> {
    let n = upload(d, index, 0)[4];
    (1..=n)
        .map(|s| {
            let v = u32_at(upload(d, index, s));
            ((v >> 16) as u16, (v >> 8) as u8, v as u8)
        })
        .collect()
}

/// `bits` bits of `frame` from bit `offset` (least significant first), as CiA 301 packs a PDO.
fn bits_of(frame: &[u8], offset: u32, bits: u32) -> u32 {
    let mut all = [0u8; 8];
    all[..frame.len()].copy_from_slice(frame);
    ((u64::from_le_bytes(all) >> offset) & ((1u64 << bits) - 1)) as u32
}

/// A value frame decoded by nothing but the mapping read over SDO agrees with the wire codec,
/// and the mapped objects read over SDO hold what the frame carried.
#[test]
fn value_frames_decode_by_the_pdo_mapping_read_over_sdo() {
    let mut d = device();
    let _ = frames(&mut d);
    let plan = IdPlan::DEFAULT;
    let id_of = |s| u32::from(plan.value_id(s).expect("in plan"));
    // TPDO1: the identifier the node sends on, valid, no RTR; event-driven.
    assert_eq!(
        u32_at(upload(&mut d, 0x1800, 1)),
        (1 << 30) | id_of(Source::Agent(ID))
    );
    assert_eq!(upload(&mut d, 0x1800, 2)[4], 0xFE);
    // RPDO1 the leader (not heard: unpinned, unsupervised), RPDO2/3 neighbours 1 and 2,
    // RPDO4.. unused.
    assert_eq!(
        u32_at(upload(&mut d, 0x1400, 1)),
        (1 << 31) | id_of(Source::Leader)
    );
    assert_eq!(u32_at(upload(&mut d, 0x1401, 1)), id_of(Source::Agent(1)));
    assert_eq!(u32_at(upload(&mut d, 0x1402, 1)), id_of(Source::Agent(2)));
    assert_eq!(u32_at(upload(&mut d, 0x1403, 1)) >> 31, 1);
    // 17 RPDOs of value frames; RPDO18 is the bench's sensor frame (not valid here).
    assert_eq!(u32_at(upload(&mut d, 0x1411, 1)) >> 31, 1);
    assert_eq!(upload(&mut d, 0x1412, 1)[0], 0x80, "18 RPDOs, no more");

    let tx_map = mapping_over_sdo(&mut d, 0x1A00);
    let rx_map = mapping_over_sdo(&mut d, 0x1602);
    assert_eq!(tx_map.iter().map(|m| u32::from(m.2)).sum::<u32>(), 32);
    d.on_frame(NMT_ID, &[0x01, 0], 20);
    let _ = (frames(&mut d), events(&mut d));
    let cases = [
        (0.0f32, 0u8),
        (1.234_567, 17),
        (-0.6, 63),
        (-127.9, 64),
        (300.0, 5),
        (f32::NAN, 9),
    ];
    for (y, seq) in cases {
        let (frame, enc): (crate::link::CanFrame, _) =
            crate::wire::encode_in(&plan, Source::Agent(2), y, seq).expect("frame");
        let data = embedded_can::Frame::data(&frame);
        let want = crate::wire::decode_payload(Source::Agent(2), data).expect("valid");
        // The frame's fields by the mapping alone.
        let mut offset = 0;
        let mut got = (None, None, None, None);
        for &(index, _, bits) in &rx_map {
            let raw = bits_of(data, offset, u32::from(bits));
            offset += u32::from(bits);
            match index {
                0x2210 => got.0 = Some(((raw << 8) as i32 >> 8) as f32 / 65536.0),
                0x2211 => got.1 = Some(raw as u8),
                0x2212 => got.2 = Some(raw == 1),
                0x2213 => got.3 = Some(raw == 1),
                _ => panic!("unexpected mapped object {index:#x}"),
            }
        }
        assert_eq!(got.1, Some(want.seq), "{y} {seq}");
        assert_eq!(got.2, Some(want.saturated), "{y} {seq}");
        assert_eq!(got.3, Some(want.y.is_none()), "{y} {seq}");
        assert_eq!(got.0, Some(want.y.unwrap_or(0.0)), "{y} {seq}");
        // The device keeps the frame heard on RPDO3 and the node's own sent one for TPDO1:
        // the mapped objects read over SDO hold the same bits.
        assert!(!d.on_frame(id_of(Source::Agent(2)) as u16, data, 30));
        d.value_sent(&enc.data);
        for map in [&rx_map, &tx_map] {
            let mut offset = 0;
            for &(index, sub, bits) in map.iter() {
                let r = upload(&mut d, index, sub);
                let len = 4 - usize::from((r[0] >> 2) & 3);
                let mut b = [0u8; 4];
                b[..len].copy_from_slice(&r[4..4 + len]);
                assert_eq!(
                    u32::from_le_bytes(b),
                    bits_of(data, offset, u32::from(bits)),
                    "{index:#x} sub {sub} of {y} {seq}"
                );
                offset += u32::from(bits);
            }
        }
    }
    // A frame of a source the node does not hear leaves the heard ones as they were.
    let before = upload(&mut d, 0x2211, 3);
    d.on_frame(id_of(Source::Agent(7)) as u16, &[0, 0, 0, 33], 40);
    assert_eq!(upload(&mut d, 0x2211, 3), before);
}

fn setting_index(s: od::Setting) -> u16 {
    SETTING_BASE
        + od::Setting::ALL
            .iter()
            .position(|t| *t == s)
            .expect("listed") as u16
}

/// The abort code of an SDO answer (0 for a confirmed download).
fn abort_of(resp: [u8; 8]) -> u32 {
    if resp[0] == 0x80 {
        u32::from_le_bytes(resp[4..8].try_into().expect("4 bytes"))
    } else {
        assert_eq!(resp[0], 0x60, "{resp:x?}");
        0
    }
}

/// The graph row over SDO as `(count, entries 1..=4)`.
fn row(d: &mut Device<2>) -> (u8, [u8; 4]) {
    let n = upload(d, param_index(Param::Neighbours), 0)[4];
    let e = core::array::from_fn(|k| upload(d, param_index(Param::Neighbours), k as u8 + 1)[4]);
    (n, e)
}

/// The identifier plan over SDO: value base, heartbeat base, agents.
fn plan(d: &mut Device<2>) -> (u16, u16, u8) {
    let u16_of = |r: [u8; 8]| u16::from_le_bytes([r[4], r[5]]);
    let base = u16_of(upload(d, setting_index(od::Setting::IdBase), 0));
    let hb = u16_of(upload(d, setting_index(od::Setting::HeartbeatIdBase), 0));
    (
        base,
        hb,
        upload(d, setting_index(od::Setting::Agents), 0)[4],
    )
}

#[test]
fn the_graph_row_and_the_plan_round_trip_and_the_rpdos_follow() {
    let mut d = device();
    frames(&mut d);
    let nb = param_index(Param::Neighbours);
    assert_eq!(row(&mut d), (2, [1, 2, 0, 0]));
    // Agent 3 hears 4, 2 and 5 instead of 1 and 2: entries beyond the count first, then the
    // count; the leader too.
    assert_eq!(abort_of(download(&mut d, nb, 3, &[5])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 1, &[4])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 0, &[3])), 0);
    let pinned = param_index(Param::Pinned);
    assert_eq!(abort_of(download(&mut d, pinned, 0, &[1])), 0);
    assert_eq!(row(&mut d), (3, [4, 2, 5, 0]));
    assert_eq!(upload(&mut d, pinned, 0)[4], 1);
    // A plan moved to 0x300 (leader), heartbeats at 0x700 + 0x80, 10 agents.
    let ib = setting_index(od::Setting::IdBase);
    let hb = setting_index(od::Setting::HeartbeatIdBase);
    let ag = setting_index(od::Setting::Agents);
    assert_eq!(abort_of(download(&mut d, ag, 0, &[10])), 0);
    assert_eq!(
        abort_of(download(&mut d, ib, 0, &0x300u16.to_le_bytes())),
        0
    );
    assert_eq!(
        abort_of(download(&mut d, hb, 0, &0x780u16.to_le_bytes())),
        0
    );
    assert_eq!(plan(&mut d), (0x300, 0x780, 10));
    // RPDO1 the leader (heard: pinned), RPDO2..4 agents 4, 2, 5, RPDO5 unused.
    let cob = |d: &mut Device<2>, k: u16| {
        u32::from_le_bytes(upload(d, 0x1400 + k, 1)[4..8].try_into().expect("4"))
    };
    assert_eq!(cob(&mut d, 0), 0x300);
    assert_eq!(cob(&mut d, 1), 0x304);
    assert_eq!(cob(&mut d, 2), 0x302);
    assert_eq!(cob(&mut d, 3), 0x305);
    assert_eq!(cob(&mut d, 4), COB_ID_INVALID);
    // No heartbeat identifiers at all: 0xFFFF.
    assert_eq!(abort_of(download(&mut d, hb, 0, &[0xFF, 0xFF])), 0);
    assert_eq!(plan(&mut d).1, 0xFFFF);
    // Not while operational.
    d.on_frame(NMT_ID, &[0x01, 0], 20);
    assert_eq!(abort_of(download(&mut d, nb, 1, &[6])), 0x0800_0022);
    assert_eq!(abort_of(download(&mut d, ag, 0, &[20])), 0x0800_0022);
    assert_eq!(row(&mut d), (3, [4, 2, 5, 0]));
}

#[test]
fn every_refused_row_or_plan_names_its_abort_and_leaves_the_values() {
    let mut d = device();
    frames(&mut d);
    let nb = param_index(Param::Neighbours);
    let pinned = param_index(Param::Pinned);
    let ib = setting_index(od::Setting::IdBase);
    let hb = setting_index(od::Setting::HeartbeatIdBase);
    let ag = setting_index(od::Setting::Agents);
    let id = setting_index(od::Setting::NodeId);
    let before = (row(&mut d), plan(&mut d), upload(&mut d, pinned, 0));
    let cases: [(&str, u16, u8, Vec<u8>, u32); 14] = [
        ("a duplicate", nb, 2, vec![1], 0x0604_0043),
        ("itself (node-ID 3)", nb, 1, vec![ID], 0x0604_0043),
        ("itself beyond the count", nb, 4, vec![ID], 0x0604_0043),
        ("agent 0", nb, 1, vec![0], 0x0609_0032),
        (
            "an agent outside the plan (99)",
            nb,
            1,
            vec![100],
            0x0609_0031,
        ),
        ("over the capacity K = 4", nb, 0, vec![5], 0x0609_0031),
        (
            "a count taking in an unset entry (0)",
            nb,
            0,
            vec![3],
            0x0604_0043,
        ),
        ("no neighbour and no leader", nb, 0, vec![0], 0x0604_0043),
        ("a node-ID that is a neighbour", id, 0, vec![2], 0x0604_0043),
        (
            "a plan without the node's neighbours",
            ag,
            0,
            vec![1],
            0x0604_0043,
        ),
        ("a plan of no agents", ag, 0, vec![0], 0x0609_0032),
        (
            "value frames beyond 11 bits",
            ib,
            0,
            0x7F0u16.to_le_bytes().to_vec(),
            0x0609_0031,
        ),
        (
            "value and heartbeat blocks overlapping",
            hb,
            0,
            0x120u16.to_le_bytes().to_vec(),
            0x0604_0043,
        ),
        (
            "a sub-index beyond the capacity",
            nb,
            5,
            vec![4],
            0x0609_0011,
        ),
    ];
    for (what, index, sub, bytes, code) in cases {
        assert_eq!(
            abort_of(download(&mut d, index, sub, &bytes)),
            code,
            "{what}: {index:#06x}/{sub}"
        );
        assert_eq!(
            (row(&mut d), plan(&mut d), upload(&mut d, pinned, 0)),
            before,
            "{what}: unchanged"
        );
    }
    // Unpinning is refused only when nothing else is heard: pin, empty the row, unpin.
    assert_eq!(abort_of(download(&mut d, pinned, 0, &[1])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 0, &[0])), 0);
    assert_eq!(abort_of(download(&mut d, pinned, 0, &[0])), 0x0604_0043);
    assert_eq!(upload(&mut d, pinned, 0)[4], 1);
}

#[test]
fn a_permuted_row_and_a_moved_plan_are_stored_and_load_onto_the_defaults() {
    let mut d = device();
    frames(&mut d);
    let nb = param_index(Param::Neighbours);
    // [1, 2] → [2, 1] (through an entry beyond the count), agents 4, 5 more in a plan of 5.
    let ag = setting_index(od::Setting::Agents);
    assert_eq!(abort_of(download(&mut d, ag, 0, &[5])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 3, &[5])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 1, &[5])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 2, &[1])), 0);
    assert_eq!(abort_of(download(&mut d, nb, 1, &[2])), 0);
    assert_eq!(row(&mut d), (2, [2, 1, 5, 0]));
    let mut buf = [0u8; 1024];
    let n = d.save(&mut buf).expect("fits");
    let mut fresh = device();
    frames(&mut fresh);
    fresh.load(&buf[..n]).expect("loads");
    assert_eq!(row(&mut fresh).0, 2);
    assert_eq!(&row(&mut fresh).1[..2], &[2, 1]);
    assert_eq!(plan(&mut fresh).2, 5);
    // A stored row the plan cannot hold is refused whole: nothing changes.
    let mut other = device();
    frames(&mut other);
    let at = buf[..n]
        .windows(4)
        .position(|w| w == [ag.to_le_bytes()[0], ag.to_le_bytes()[1], 0, 1])
        .expect("the agents record");
    let mut bad = buf;
    bad[at + 4] = 1;
    let before = (row(&mut other), plan(&mut other));
    assert!(other.load(&bad[..n]).is_err());
    assert_eq!((row(&mut other), plan(&mut other)), before);
}

/// A written or restored row is a pending change the node must adopt at a reset
/// (`graph_written`); a gain is not.
#[test]
fn a_written_or_restored_row_is_pending_until_adopted() {
    let mut d = device();
    frames(&mut d);
    let zeta = param_index(Param::Zeta);
    assert_eq!(
        abort_of(download(&mut d, zeta, 0, &0.2f32.to_le_bytes())),
        0
    );
    assert!(!d.graph_written(), "a gain is not the graph");
    let nb = param_index(Param::Neighbours);
    assert_eq!(abort_of(download(&mut d, nb, 1, &[4])), 0);
    assert!(d.graph_written());
    d.graph_adopted();
    assert!(!d.graph_written());
    assert_eq!(
        abort_of(download(&mut d, 0x1011, 1, &LOAD_SIGNATURE.to_le_bytes())),
        0
    );
    assert!(d.graph_written(), "the defaults' row waits for a reset too");
    assert_eq!(row(&mut d), (2, [1, 2, 0, 0]));
}

/// A node that sends its own heartbeat needs heartbeat identifiers: the plan cannot drop them.
#[test]
fn a_plan_without_heartbeat_ids_is_refused_for_a_node_with_a_heartbeat() {
    let mut node = NodeConfig::new(ID, [1, 2, 0, 0], 2_500);
    node.heartbeat_period_us = 100_000;
    let ctrl = ControllerConfig::<2> {
        neighbour_count: 2,
        ..ControllerConfig::default()
    };
    let store = ParamStore::new(node.identity(), &ctrl).expect("representable");
    let mut d = Device::new(store, Identity::default(), false);
    d.boot(0);
    frames(&mut d);
    let hb = setting_index(od::Setting::HeartbeatIdBase);
    assert_eq!(
        abort_of(download(&mut d, hb, 0, &[0xFF, 0xFF])),
        0x0604_0043
    );
    assert_eq!(plan(&mut d).1, 0x780, "unchanged");
}

/// The status PDO (TPDO2) decoded by nothing but its mapping read over SDO gives the fields of
/// `wire::Heartbeat`, bit-exact with today's frame, and the mapped objects read over SDO hold
/// what the node sent last.
#[test]
fn the_status_pdo_decodes_by_its_mapping_read_over_sdo() {
    use crate::supervisor::{Lost, NodeState};
    use crate::wire::Heartbeat;
    let mut d = device();
    let _ = frames(&mut d);
    // TPDO2 on the plan's heartbeat identifier of this node, valid, no RTR; event-driven.
    assert_eq!(
        u32_at(upload(&mut d, 0x1801, 1)),
        (1 << 30) | u32::from(IdPlan::DEFAULT.heartbeat_id(ID).expect("in plan"))
    );
    assert_eq!(upload(&mut d, 0x1801, 2)[4], 0xFE);
    // Before any status PDO: boot, nothing lost.
    assert_eq!(upload(&mut d, 0x2220, 0)[4], 1);
    let map = mapping_over_sdo(&mut d, 0x1A01);
    assert_eq!(map.iter().map(|m| u32::from(m.2)).sum::<u32>(), 64);
    let cases = [
        Heartbeat {
            state: NodeState::Safe,
            lost: Lost::from_bits(0b101),
            boot_count: 0x1234,
            overruns: 65_535,
            safe_entries: 7,
        },
        Heartbeat {
            state: NodeState::Fault,
            lost: Lost::from_bits(0b010),
            boot_count: 0,
            overruns: 300,
            safe_entries: 65_000,
        },
    ];
    for hb in cases {
        let data = hb.to_bytes();
        let mut offset = 0;
        let mut got = [0u32; 5];
        for &(index, sub, bits) in &map {
            assert_eq!(sub, 0, "{index:#x}");
            let k = usize::from(index - 0x2220);
            got[k] = bits_of(&data, offset, u32::from(bits));
            offset += u32::from(bits);
        }
        assert_eq!(
            got,
            [
                u32::from(hb.state.code()),
                u32::from(hb.lost.bits()),
                u32::from(hb.boot_count),
                u32::from(hb.overruns),
                u32::from(hb.safe_entries),
            ]
        );
        d.status_sent(&data);
        for (k, want) in got.iter().enumerate() {
            let r = upload(&mut d, 0x2220 + k as u16, 0);
            let len = 4 - usize::from((r[0] >> 2) & 3);
            assert_eq!(len, if k < 2 { 1 } else { 2 }, "{k}");
            let mut b = [0u8; 4];
            b[..len].copy_from_slice(&r[4..4 + len]);
            assert_eq!(u32::from_le_bytes(b), *want, "{k}");
        }
    }
}

/// A bench's sensor and command frames are RPDO18 and TPDO3 once the runtime says its plant is
/// on the bus: a command frame of `plant_bus` decoded by nothing but the mapping read over SDO
/// gives its two `f32`, and the mapped objects read over SDO hold the last frames.
#[test]
fn bench_frames_decode_by_the_plant_pdo_mapping_read_over_sdo() {
    let mut d = device();
    let _ = frames(&mut d);
    // Not a bench: both PDOs present, not valid.
    assert_eq!(u32_at(upload(&mut d, 0x1411, 1)), (1 << 31) | 0x203);
    assert_eq!(
        u32_at(upload(&mut d, 0x1802, 1)),
        (1 << 31) | (1 << 30) | 0x303
    );
    d.enable_plant_pdos();
    assert_eq!(u32_at(upload(&mut d, 0x1411, 1)), 0x203);
    assert_eq!(u32_at(upload(&mut d, 0x1802, 1)), (1 << 30) | 0x303);
    assert_eq!(upload(&mut d, 0x1802, 2)[4], 0xFE);
    let sensor_map = mapping_over_sdo(&mut d, 0x1611);
    let command_map = mapping_over_sdo(&mut d, 0x1A02);
    assert_eq!(sensor_map, [(0x2230, 1, 32), (0x2230, 2, 32)]);
    assert_eq!(command_map, [(0x2231, 1, 32), (0x2231, 2, 32)]);
    // Nothing heard yet: NaN.
    assert!(f32::from_bits(u32_at(upload(&mut d, 0x2230, 1))).is_nan());
    for q in [[0.5f32, -1.25], [f32::MAX, -0.0], [1e-30, 3.0]] {
        let f: crate::link::CanFrame =
            crate::plant_bus::pair_frame(crate::plant_bus::Kind::Command, ID, q).expect("frame");
        let data = embedded_can::Frame::data(&f);
        let mut offset = 0;
        let mut got = [0f32; 2];
        for &(_, sub, bits) in &command_map {
            got[usize::from(sub) - 1] = f32::from_bits(bits_of(data, offset, u32::from(bits)));
            offset += u32::from(bits);
        }
        assert_eq!(got.map(f32::to_bits), q.map(f32::to_bits));
        d.command_sent(q);
        d.sensor_received([q[1], q[0]]);
        for (k, &(index, sub, _)) in command_map.iter().chain(&sensor_map).enumerate() {
            let want = if k < 2 { q[k] } else { q[3 - k] };
            assert_eq!(
                u32_at(upload(&mut d, index, sub)),
                want.to_bits(),
                "{index:#x}/{sub}"
            );
        }
    }
    assert!(OBJECTS.windows(2).all(|w| w[0].index < w[1].index));
}
