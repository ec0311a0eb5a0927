//! Finite-element model of the PneuNets actuator.
