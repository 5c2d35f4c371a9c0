//! Session commands: CONNECT, DISCONNECT, GET_STATUS, GET_COMM_MODE_INFO, GET_ID,
//! SET_REQUEST, GET_SEED, UNLOCK (SYNCH is answered by the dispatcher).

use crate::access::{Mta, Virtual};
use crate::key::{derive_seed, verify_key, KEY_LEN, SEED_LEN};
use crate::memory::{Calibration, Platform};
use crate::protocol::{
    request, resource, session, ErrorCode, DRIVER_VERSION, MAX_BS, MAX_CTO, MAX_DTO,
    PROTOCOL_LAYER_VERSION, TRANSPORT_LAYER_VERSION,
};
use crate::response::Responses;
use crate::slave::{PendingSeed, Slave};
use crate::wire::{byte, bytes, CmdResult};

/// COMM_MODE_BASIC: bit 7 OPTIONAL (GET_COMM_MODE_INFO available), bit 6 SLAVE_BLOCK_MODE,
/// bits 1–2 address granularity BYTE (0), bit 0 byte order Intel (0).
pub(crate) const COMM_MODE_BASIC: u8 = 0xC0;
/// COMM_MODE_OPTIONAL: bit 0 MASTER_BLOCK_MODE (interleaved mode, bit 1, not supported).
pub(crate) const COMM_MODE_OPTIONAL: u8 = 0x01;
/// GET_ID identification type served: ASAM-MC2 file name without path and extension.
pub(crate) const ID_TYPE_ASAM_MC2_NAME: u8 = 1;
/// GET_ID mode: bit 0 clear = the identification is uploaded from the MTA (pyxcp's
/// `identifier()` takes bit 0 set to mean "inline in the response", which cannot fit a CAN
/// frame after the 7 fixed bytes).
pub(crate) const ID_MODE_UPLOAD: u8 = 0x00;

impl Slave {
    /// CONNECT `FF mode`: mode 0 (normal) only. Always answered, also while connected (the
    /// session then starts afresh). Response `FF resource comm_mode_basic max_cto
    /// max_dto(u16) protocol_version transport_version`.
    pub(crate) fn connect(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let mode = byte(cto, 1)?;
        if mode != 0 {
            return Err(ErrorCode::OutOfRange.into());
        }
        self.connected = true;
        self.reset_session();
        let [dto_lo, dto_hi] = (MAX_DTO as u16).to_le_bytes();
        out.ok(&[
            resource::OFFERED,
            COMM_MODE_BASIC,
            MAX_CTO as u8,
            dto_lo,
            dto_hi,
            PROTOCOL_LAYER_VERSION,
            TRANSPORT_LAYER_VERSION,
        ]);
        Ok(())
    }

    /// DISCONNECT `FE`: answered `FF`, then the session ends ([`Slave::disconnect`]).
    pub(crate) fn cmd_disconnect(&mut self, out: &mut Responses) -> CmdResult {
        out.ok(&[]);
        self.disconnect();
        Ok(())
    }

    /// GET_STATUS `FD`: `FF session_status protection reserved session_config_id(u16 = 0)`.
    pub(crate) fn get_status(&mut self, out: &mut Responses) -> CmdResult {
        let mut status = 0;
        if self.daq.running() {
            status |= session::DAQ_RUNNING;
        }
        if self.store_pending {
            status |= session::STORE_CAL_REQ;
        }
        out.ok(&[status, self.protected, 0, 0, 0]);
        Ok(())
    }

    /// SET_REQUEST `F9 mode session_config_id(u16)`: mode STORE_CAL_REQ only (needs CAL/PAG
    /// unlocked). The application takes the request ([`Calibration::request_store`]) or says
    /// why not; taken, GET_STATUS says pending until [`Slave::store_finished`]. A request
    /// while one is pending is answered `FF` and joins it.
    pub(crate) fn set_request(
        &mut self,
        cto: &[u8],
        target: &mut impl Calibration,
        out: &mut Responses,
    ) -> CmdResult {
        self.require_unlocked(resource::CAL_PAG)?;
        let mode = byte(cto, 1)?;
        if mode != request::STORE_CAL_REQ {
            return Err(ErrorCode::OutOfRange.into());
        }
        if !self.store_pending {
            target.request_store().map_err(|r| r.xcp_error())?;
            self.store_pending = true;
        }
        out.ok(&[]);
        Ok(())
    }

    /// GET_COMM_MODE_INFO `FB`: `FF reserved comm_mode_optional reserved max_bs min_st
    /// queue_size driver_version`.
    pub(crate) fn get_comm_mode_info(&mut self, out: &mut Responses) -> CmdResult {
        out.ok(&[0, COMM_MODE_OPTIONAL, 0, MAX_BS, 0, 0, DRIVER_VERSION]);
        Ok(())
    }

    /// GET_ID `FA type`: type 1 only. `FF mode(0) reserved(2) length(u32)`; the MTA then
    /// points at the string for UPLOAD.
    pub(crate) fn get_id(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        if byte(cto, 1)? != ID_TYPE_ASAM_MC2_NAME {
            return Err(ErrorCode::OutOfRange.into());
        }
        // `SlaveConfig::validate` checked that the length fits a u32.
        let len = u32::try_from(self.config.id.len()).map_err(|_| ErrorCode::OutOfRange)?;
        self.mta = Mta::Virtual {
            area: Virtual::Id,
            offset: 0,
        };
        let [l0, l1, l2, l3] = len.to_le_bytes();
        out.ok(&[ID_MODE_UPLOAD, 0, 0, l0, l1, l2, l3]);
        Ok(())
    }

    /// GET_SEED `F8 mode resource`: mode 0 (the seed fits one frame) and one offered resource.
    /// `FF 06 seed(6)` for a locked resource, `FF 00` for an unlocked one.
    pub(crate) fn get_seed(
        &mut self,
        cto: &[u8],
        platform: &mut impl Platform,
        out: &mut Responses,
    ) -> CmdResult {
        let mode = byte(cto, 1)?;
        let res = byte(cto, 2)?;
        if mode != 0 || !matches!(res, resource::CAL_PAG | resource::DAQ) {
            return Err(ErrorCode::OutOfRange.into());
        }
        if self.protected & res == 0 {
            self.seed = None;
            out.ok(&[0]);
            return Ok(());
        }
        self.seed_counter = self.seed_counter.wrapping_add(1);
        let a = platform.seed_entropy();
        let b = platform.seed_entropy();
        let seed = derive_seed(self.seed_counter, a, b);
        self.seed = Some(PendingSeed {
            resource: res,
            seed,
        });
        let mut payload = [0_u8; 1 + SEED_LEN];
        payload[0] = SEED_LEN as u8;
        if let Some(dst) = payload.get_mut(1..) {
            dst.copy_from_slice(&seed);
        }
        out.ok(&payload);
        Ok(())
    }

    /// UNLOCK `F7 length key…`: needs the seed of the GET_SEED just before (else
    /// `ERR_SEQUENCE`); one try per seed. A 6-byte key that matches unlocks the resource
    /// (`FF protection`); anything else answers `ERR_ACCESS_LOCKED` and disconnects.
    pub(crate) fn unlock(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let pending = self.seed.take().ok_or(ErrorCode::Sequence)?;
        let length = byte(cto, 1)?;
        let key_ok = if usize::from(length) == KEY_LEN {
            let key = bytes(cto, 2, KEY_LEN)?;
            verify_key(self.config.secret, pending.resource, &pending.seed, key)
        } else {
            false
        };
        if !key_ok {
            self.disconnect();
            return Err(ErrorCode::AccessLocked.into());
        }
        self.protected &= !pending.resource;
        out.ok(&[self.protected]);
        Ok(())
    }
}
