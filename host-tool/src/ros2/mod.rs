//! ROS 2 bags (rosbag2; MCAP or sqlite3 storage read, MCAP written): the robot's bag that
//! `merge` reads beside a board log, and the bags `convert --to ros2-bag` and `demo --robot-bag`
//! write. Messages are CDR-encoded ([`cdr`]); the standard types used are in [`msgs`].

pub mod cdr;
pub mod from_log;
pub mod layout;
pub mod msgs;
pub mod read;
pub mod robot_bag;
pub mod write;
