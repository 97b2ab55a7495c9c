//! The electronic data sheet (CiA 306 EDS) of a [`Device`], written from the same table
//! ([`super::od::OBJECTS`]) the SDO server serves: every object with `ParameterName`,
//! `ObjectType`, `DataType`, `AccessType`, `PDOMapping` and the device's present value as
//! `DefaultValue` (COB-IDs as `$NODEID+…`); integer ranges as `LowLimit`/`HighLimit`. A
//! manufacturer entry is preceded by a comment line with its unit and range (`REAL32` ranges
//! are only stated there: the device checks them, with the scenario file's constructors).

use core::fmt::{self, Write};

use controller_core::param::Range;

use super::od::{self, DataType, Item, Kind, Object, Value, OBJECTS};
use super::{Device, DEVICE_NAME};

/// The base `b` of an entry written `$NODEID+b` (a COB-ID that follows the node-ID).
fn hex_id<const N: usize>(d: &Device<N>, item: Item, sub: u8) -> Option<u32> {
    match (item, sub) {
        (Item::EmcyCobId, _) => Some(0x80),
        (Item::SdoServer, 1) => Some(0x600),
        (Item::SdoServer, 2) => Some(0x580),
        (Item::TpdoComm, 1) => Some(od::COB_ID_NO_RTR | u32::from(d.id_plan().value_base())),
        (Item::SensorComm, 1) => Some(d.plant_cob_id(true) - u32::from(d.node_id())),
        (Item::CommandComm, 1) => Some(d.plant_cob_id(false) - u32::from(d.node_id())),
        (Item::StatusComm, 1) => d
            .id_plan()
            .heartbeat_base()
            .map(|b| od::COB_ID_NO_RTR | u32::from(b)),
        _ => None,
    }
}

fn limits(o: &Object) -> Option<(u32, u32)> {
    match o.item {
        Item::Param(p) => match p.spec().range {
            Range::Count { min, max } => Some((min as u32, max.min(255) as u32)),
            Range::OneOf(names) => Some((0, names.len().saturating_sub(1) as u32)),
            _ => None,
        },
        Item::Setting(s) => {
            let spec = s.spec();
            match (s, spec.data_type) {
                _ if !spec.names.is_empty() => Some((0, spec.names.len().saturating_sub(1) as u32)),
                (od::Setting::Agents, _) => Some((1, u32::from(u8::MAX))),
                (od::Setting::HeartbeatIdBase, _) => Some((0, u32::from(u16::MAX))),
                (_, DataType::Unsigned16) => Some((0, 0x7FF)),
                (_, DataType::Unsigned8) => Some((1, u32::from(super::MAX_NODE_ID))),
                _ => None,
            }
        }
        _ => None,
    }
}

/// Writes through to `W` with every non-ASCII character replaced (`–` by `-`), as EDS files
/// are read as ISO 8859-1 or ASCII.
struct Ascii<'a, W>(&'a mut W);

impl<W: Write> Write for Ascii<'_, W> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            self.0.write_char(match c {
                c if c.is_ascii() => c,
                '–' => '-',
                _ => '?',
            })?;
        }
        Ok(())
    }
}

fn comment<W: Write>(w: &mut W, o: &Object) -> fmt::Result {
    let w = &mut Ascii(w);
    match o.item {
        Item::Param(controller_core::Param::Neighbours) => writeln!(
            w,
            "; graph.neighbours: the graph row; sub-index 0 how many are heard (<= the capacity), entries distinct agents of the plan other than the node-ID; written in pre-operational, applied at reset"
        ),
        Item::Param(controller_core::Param::Pinned) => writeln!(
            w,
            "; graph.pinned: the node hears the leader (b_i); written in pre-operational, applied at reset"
        ),
        Item::Param(p) => {
            let spec = p.spec();
            write!(
                w,
                "; {}: unit {}, range {}",
                spec.key, spec.unit, spec.range
            )?;
            if let Range::OneOf(_) = spec.range {
                w.write_str(" (by position, from 0)")?;
            }
            if spec.per_step {
                w.write_str(", one per step")?;
            }
            writeln!(w, "{}", spec.condition)
        }
        Item::Setting(s) => {
            let spec = s.spec();
            write!(
                w,
                "; {}: unit {}, range {}",
                spec.key, spec.unit, spec.range
            )?;
            for (k, n) in spec.names.iter().enumerate() {
                write!(w, "{}{k} = {n}", if k == 0 { ": " } else { ", " })?;
            }
            writeln!(w)
        }
        _ => Ok(()),
    }
}

fn value<W: Write>(w: &mut W, t: DataType, bytes: &[u8]) -> fmt::Result {
    match (t, Value::decode(t, bytes)) {
        (DataType::VisibleString, _) => {
            for &b in bytes {
                w.write_char(char::from(b))?;
            }
            Ok(())
        }
        (_, Ok(Value::Real(v))) => write!(w, "{v:?}"),
        (_, Ok(Value::Bool(b))) => write!(w, "{}", u8::from(b)),
        (_, Ok(Value::Unsigned(u))) => write!(w, "0x{u:X}"),
        (_, Err(_)) => Ok(()),
    }
}

#[allow(clippy::too_many_arguments)]
fn var<W: Write, const N: usize>(
    w: &mut W,
    d: &Device<N>,
    o: &Object,
    section: fmt::Arguments<'_>,
    name: &str,
    sub: u8,
    t: DataType,
    access: &str,
) -> fmt::Result {
    writeln!(w, "[{section}]")?;
    writeln!(w, "ParameterName={name}")?;
    writeln!(w, "ObjectType=0x7")?;
    writeln!(w, "DataType=0x{:04X}", t.code())?;
    writeln!(w, "AccessType={access}")?;
    if let Some(base) = hex_id(d, o.item, sub) {
        writeln!(w, "DefaultValue=$NODEID+0x{base:X}")?;
    } else if let Ok(bytes) = d.read(o.index, sub) {
        w.write_str("DefaultValue=")?;
        value(w, t, bytes.as_slice())?;
        writeln!(w)?;
    }
    if sub > 0 || o.kind == Kind::Var {
        if let Some((lo, hi)) = limits(o) {
            writeln!(w, "LowLimit=0x{lo:X}")?;
            writeln!(w, "HighLimit=0x{hi:X}")?;
        }
    }
    // Sub-index 0 of an array (its length) is never mapped.
    let mappable = o.pdo && (sub > 0 || o.kind == Kind::Var);
    writeln!(w, "PDOMapping={}", u8::from(mappable))?;
    writeln!(w)
}

fn object<W: Write, const N: usize>(w: &mut W, d: &Device<N>, o: &Object) -> fmt::Result {
    comment(w, o)?;
    let access = o.access.eds();
    match o.kind {
        Kind::Var => var(
            w,
            d,
            o,
            format_args!("{:04X}", o.index),
            o.name(),
            0,
            o.data_type,
            access,
        ),
        Kind::Array { .. } | Kind::Record { .. } => {
            // The error field lists every entry it may hold, full or not.
            let subs = match (o.item, o.kind) {
                (Item::ErrorField, Kind::Array { len }) => len,
                _ => d.sub_count(o),
            };
            let code = if matches!(o.kind, Kind::Array { .. }) {
                8
            } else {
                9
            };
            writeln!(w, "[{:04X}]", o.index)?;
            writeln!(w, "ParameterName={}", o.name())?;
            writeln!(w, "ObjectType=0x{code:X}")?;
            writeln!(w, "SubNumber=0x{:X}", u16::from(subs) + 1)?;
            writeln!(w)?;
            let sub0_access = match o.item {
                Item::ErrorField => "rw",
                // The graph row: how many entries are heard.
                Item::Param(controller_core::Param::Neighbours) => "rw",
                _ => "ro",
            };
            var(
                w,
                d,
                o,
                format_args!("{:04X}sub0", o.index),
                super::od::sub_name(o, 0),
                0,
                DataType::Unsigned8,
                sub0_access,
            )?;
            for sub in 1..=subs {
                var(
                    w,
                    d,
                    o,
                    format_args!("{:04X}sub{sub:X}", o.index),
                    super::od::sub_name(o, sub),
                    sub,
                    od::sub_data_type(o, sub),
                    access,
                )?;
            }
            Ok(())
        }
    }
}

fn list<W: Write>(w: &mut W, section: &str, pick: impl Fn(u16) -> bool) -> fmt::Result {
    writeln!(w, "[{section}]")?;
    let n = OBJECTS.iter().filter(|o| pick(o.index)).count();
    writeln!(w, "SupportedObjects={n}")?;
    for (k, o) in OBJECTS.iter().filter(|o| pick(o.index)).enumerate() {
        writeln!(w, "{}=0x{:04X}", k + 1, o.index)?;
    }
    writeln!(w)
}

/// Write the EDS of `device` (its values as `DefaultValue`); `file_name` goes into
/// `[FileInfo]`.
///
/// ```
/// use agent_node::canopen::eds::{reference_device, write_eds};
/// let dev = reference_device().unwrap();
/// let mut eds = String::new();
/// write_eds(&mut eds, &dev, "agent-node.eds").unwrap();
/// assert!(eds.contains("FileName=agent-node.eds"));
/// assert!(eds.contains("[2000]")); // the first controller parameter
/// assert!(eds.contains("ParameterName=controller.ts"));
/// ```
pub fn write_eds<W: Write, const N: usize>(
    w: &mut W,
    device: &Device<N>,
    file_name: &str,
) -> fmt::Result {
    writeln!(w, "; CiA 306 electronic data sheet of the agent node, written by agent_node::canopen::eds from its object dictionary.")?;
    writeln!(w, "; Manufacturer entries 0x2000.. are controller_core::param (scenario keys, docs/SCENARIO.md); 0x2100.. the node's settings.")?;
    writeln!(w, "; REAL32 ranges are checked by the device (SDO abort 0x06090030/31/32 or 0x06040043); optional numbers read NaN when absent.")?;
    writeln!(w)?;
    writeln!(w, "[FileInfo]")?;
    writeln!(w, "FileName={file_name}")?;
    writeln!(w, "FileVersion=1")?;
    writeln!(w, "FileRevision=0")?;
    writeln!(w, "EDSVersion=4.0")?;
    writeln!(
        w,
        "Description=Follower node of the predefined-time adaptive consensus controller"
    )?;
    writeln!(w, "CreatedBy=agent_node::canopen::eds")?;
    writeln!(w)?;
    writeln!(w, "[DeviceInfo]")?;
    writeln!(w, "VendorName=none")?;
    writeln!(w, "VendorNumber=0x{:X}", device.identity.vendor)?;
    writeln!(w, "ProductName={DEVICE_NAME}")?;
    writeln!(w, "ProductNumber=0x{:X}", device.identity.product)?;
    writeln!(w, "RevisionNumber=0x{:X}", device.identity.revision)?;
    for rate in [10, 20, 50, 125, 250, 500, 800, 1000] {
        writeln!(w, "BaudRate_{rate}={}", u8::from(rate >= 125))?;
    }
    writeln!(w, "SimpleBootUpMaster=0")?;
    writeln!(w, "SimpleBootUpSlave=1")?;
    // PDOs map fields bit by bit (the value frame's 6-bit counter and 1-bit flags).
    writeln!(w, "Granularity=1")?;
    writeln!(w, "DynamicChannelsSupported=0")?;
    writeln!(w, "GroupMessaging=0")?;
    writeln!(w, "NrOfRXPDO={}", od::RPDOS)?;
    writeln!(w, "NrOfTXPDO=1")?;
    writeln!(w, "LSS_Supported=0")?;
    writeln!(w)?;
    writeln!(w, "[DummyUsage]")?;
    for t in 1..=7 {
        writeln!(w, "Dummy000{t}=0")?;
    }
    writeln!(w)?;
    let mandatory = |i: u16| matches!(i, 0x1000 | 0x1001 | 0x1018);
    list(w, "MandatoryObjects", mandatory)?;
    list(w, "OptionalObjects", |i| i < 0x2000 && !mandatory(i))?;
    list(w, "ManufacturerObjects", |i| (0x2000..0x6000).contains(&i))?;
    for o in OBJECTS.iter() {
        object(w, device, o)?;
    }
    Ok(())
}

/// The device `docs/agent-node.eds` describes: agent 1 of the default configuration
/// (`ControllerConfig::default()`: Example 1's `n = 2`, pinned, no neighbours), node-ID 1, in
/// the default identifier plan, with room for the most neighbours a node hears
/// (`graph.neighbours` lists [`crate::wire::MAX_NEIGHBOURS`] entries, all unused).
///
/// ```
/// use agent_node::canopen::{eds::reference_device, NmtState};
/// let dev = reference_device().unwrap();
/// assert_eq!(dev.node_id(), 1); // agent 1 of Example 1, pinned, no neighbours
/// assert_eq!(dev.nmt(), NmtState::Initialising); // not booted
/// assert!(dev.store.controller().unwrap().pinned);
/// ```
#[must_use]
pub fn reference_device() -> Option<Device<2>> {
    let node = crate::node::NodeConfig::new(1, [0; crate::wire::MAX_NEIGHBOURS], 1);
    let controller = controller_core::ControllerConfig::<2>::default();
    let store = super::od::ParamStore::new(node.identity(), &controller).ok()?;
    Some(Device::new(store, super::Identity::default(), false))
}
