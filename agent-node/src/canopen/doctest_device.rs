// The device of the doctests on `Device` (each includes this file; it is no module of the
// crate): `device()`, agent 2 hearing agent 1 and the leader (node-ID 2), booted at t = 0,
// pre-operational, with its boot-up message and first event taken.
pub use agent_node::canopen::{od::ParamStore, Device, Identity};
pub use agent_node::NodeConfig;
pub use controller_core::ControllerConfig;

pub fn device() -> Device<2> {
    let ctrl = ControllerConfig::<2> {
        neighbour_count: 1,
        ..Default::default()
    };
    let store = ParamStore::new(NodeConfig::new(2, [1], 2_500).identity(), &ctrl)
        .expect("agent 2 has a CANopen device");
    let mut dev = Device::new(store, Identity::default(), false);
    dev.boot(0);
    while dev.next_tx().is_some() {}
    while dev.next_event().is_some() {}
    dev
}
