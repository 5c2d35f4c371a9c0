//! The commands, one module per group; each is an `impl Slave` block whose functions parse
//! the request, check it and push the positive response (errors are answered by
//! [`Slave::handle`](crate::Slave::handle)).

pub(crate) mod daq;
mod memory;
mod paging;
mod standard;
