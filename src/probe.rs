//! Virtual-time driver: simulated ship and monitor core in lockstep.
