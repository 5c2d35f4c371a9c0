//! Fixed protocol numbers: packet identifiers, command codes, error codes and the limits of
//! XCP on CAN this slave implements (ASAM MCD-1 XCP 1.x protocol layer).

/// Largest command / response packet (CTO): one classic CAN frame.
pub const MAX_CTO: usize = 8;
/// Largest data packet (DTO): one classic CAN frame.
pub const MAX_DTO: usize = 8;
/// Protocol layer version reported by CONNECT (major byte only).
pub const PROTOCOL_LAYER_VERSION: u8 = 1;
/// Transport layer version reported by CONNECT (major byte only).
pub const TRANSPORT_LAYER_VERSION: u8 = 1;
/// XCP driver version reported by GET_COMM_MODE_INFO (this crate's 0.1).
pub const DRIVER_VERSION: u8 = 0x01;
/// Master block mode: most frames in one DOWNLOAD block (DOWNLOAD plus DOWNLOAD_NEXTs).
/// `MAX_BS × (MAX_CTO − 2) = 252` bytes, the largest multiple of 6 not above 255.
pub const MAX_BS: u8 = 42;
/// Largest DOWNLOAD block in bytes (`MAX_BS × 6`).
pub const MAX_BLOCK_BYTES: usize = MAX_BS as usize * (MAX_CTO - 2);
/// Data bytes of one UPLOAD response frame (PID + 7).
pub const UPLOAD_BYTES_PER_FRAME: usize = MAX_CTO - 1;
/// Most response frames one command produces: UPLOAD of 255 bytes, 7 per frame.
pub const MAX_RESPONSE_FRAMES: usize = 255_usize.div_ceil(UPLOAD_BYTES_PER_FRAME);

/// Packet identifiers, slave → master.
pub mod pid {
    /// Positive response.
    pub const RES: u8 = 0xFF;
    /// Error (negative response).
    pub const ERR: u8 = 0xFE;
    /// Event packet (EV_STORE_CAL only).
    pub const EV: u8 = 0xFD;
    /// Service request packet (not sent by this slave).
    pub const SERV: u8 = 0xFC;
    /// Highest PID of a DTO (absolute ODT number).
    pub const MAX_DTO_PID: u8 = 0xFB;
}

/// SET_REQUEST mode bits.
pub mod request {
    /// STORE_CAL_REQ: store the working page in non-volatile memory.
    pub const STORE_CAL_REQ: u8 = 0x01;
}

/// Event codes (second byte of an event packet `FD code`).
pub mod event {
    /// EV_STORE_CAL: the calibration store requested by SET_REQUEST is done.
    pub const STORE_CAL: u8 = 0x03;
}

/// GET_STATUS session status bits.
pub mod session {
    /// STORE_CAL_REQ pending: a calibration store is requested and not done yet.
    pub const STORE_CAL_REQ: u8 = 0x01;
    /// DAQ_RUNNING: at least one DAQ list runs.
    pub const DAQ_RUNNING: u8 = 0x40;
}

/// Command codes (first byte of a command packet).
pub mod cmd {
    /// CONNECT.
    pub const CONNECT: u8 = 0xFF;
    /// DISCONNECT.
    pub const DISCONNECT: u8 = 0xFE;
    /// GET_STATUS.
    pub const GET_STATUS: u8 = 0xFD;
    /// SYNCH.
    pub const SYNCH: u8 = 0xFC;
    /// GET_COMM_MODE_INFO.
    pub const GET_COMM_MODE_INFO: u8 = 0xFB;
    /// GET_ID.
    pub const GET_ID: u8 = 0xFA;
    /// GET_SEED.
    pub const GET_SEED: u8 = 0xF8;
    /// UNLOCK.
    pub const UNLOCK: u8 = 0xF7;
    /// SET_REQUEST.
    pub const SET_REQUEST: u8 = 0xF9;
    /// SET_MTA.
    pub const SET_MTA: u8 = 0xF6;
    /// UPLOAD.
    pub const UPLOAD: u8 = 0xF5;
    /// SHORT_UPLOAD.
    pub const SHORT_UPLOAD: u8 = 0xF4;
    /// DOWNLOAD.
    pub const DOWNLOAD: u8 = 0xF0;
    /// DOWNLOAD_NEXT.
    pub const DOWNLOAD_NEXT: u8 = 0xEF;
    /// SET_CAL_PAGE.
    pub const SET_CAL_PAGE: u8 = 0xEB;
    /// GET_CAL_PAGE.
    pub const GET_CAL_PAGE: u8 = 0xEA;
    /// GET_PAG_PROCESSOR_INFO.
    pub const GET_PAG_PROCESSOR_INFO: u8 = 0xE9;
    /// GET_SEGMENT_INFO.
    pub const GET_SEGMENT_INFO: u8 = 0xE8;
    /// GET_PAGE_INFO.
    pub const GET_PAGE_INFO: u8 = 0xE7;
    /// COPY_CAL_PAGE.
    pub const COPY_CAL_PAGE: u8 = 0xE4;
    /// SET_DAQ_PTR.
    pub const SET_DAQ_PTR: u8 = 0xE2;
    /// WRITE_DAQ.
    pub const WRITE_DAQ: u8 = 0xE1;
    /// SET_DAQ_LIST_MODE.
    pub const SET_DAQ_LIST_MODE: u8 = 0xE0;
    /// GET_DAQ_LIST_MODE.
    pub const GET_DAQ_LIST_MODE: u8 = 0xDF;
    /// START_STOP_DAQ_LIST.
    pub const START_STOP_DAQ_LIST: u8 = 0xDE;
    /// START_STOP_SYNCH.
    pub const START_STOP_SYNCH: u8 = 0xDD;
    /// GET_DAQ_CLOCK.
    pub const GET_DAQ_CLOCK: u8 = 0xDC;
    /// GET_DAQ_PROCESSOR_INFO.
    pub const GET_DAQ_PROCESSOR_INFO: u8 = 0xDA;
    /// GET_DAQ_RESOLUTION_INFO.
    pub const GET_DAQ_RESOLUTION_INFO: u8 = 0xD9;
    /// GET_DAQ_EVENT_INFO.
    pub const GET_DAQ_EVENT_INFO: u8 = 0xD7;
    /// FREE_DAQ.
    pub const FREE_DAQ: u8 = 0xD6;
    /// ALLOC_DAQ.
    pub const ALLOC_DAQ: u8 = 0xD5;
    /// ALLOC_ODT.
    pub const ALLOC_ODT: u8 = 0xD4;
    /// ALLOC_ODT_ENTRY.
    pub const ALLOC_ODT_ENTRY: u8 = 0xD3;
}

/// Resource bits (CONNECT resource byte, GET_STATUS protection mask, GET_SEED, UNLOCK).
pub mod resource {
    /// Calibration and page switching.
    pub const CAL_PAG: u8 = 0x01;
    /// Data acquisition.
    pub const DAQ: u8 = 0x04;
    /// Stimulation (not offered).
    pub const STIM: u8 = 0x08;
    /// Flash programming (not offered).
    pub const PGM: u8 = 0x10;
    /// The resources this slave offers, all protected on CONNECT.
    pub const OFFERED: u8 = CAL_PAG | DAQ;
}

/// The standard's error codes, the second byte of an error packet (`0xFE code`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum ErrorCode {
    /// Command processor synchronisation (the answer to SYNCH).
    CmdSynch = 0x00,
    /// Command not executed, slave busy (not used).
    CmdBusy = 0x10,
    /// Command rejected because DAQ is running.
    DaqActive = 0x11,
    /// Command rejected because PGM is running (not used).
    PgmActive = 0x12,
    /// Unknown command or optional command not implemented.
    CmdUnknown = 0x20,
    /// Command syntax invalid (packet too short or too long).
    CmdSyntax = 0x21,
    /// Parameter out of range.
    OutOfRange = 0x22,
    /// Memory location write protected (the reference page).
    WriteProtected = 0x23,
    /// Memory location not accessible (outside every permitted region).
    AccessDenied = 0x24,
    /// Resource protected: seed & key required (or a wrong key was given).
    AccessLocked = 0x25,
    /// Page not valid.
    PageNotValid = 0x26,
    /// Page mode not valid.
    ModeNotValid = 0x27,
    /// Segment not valid.
    SegmentNotValid = 0x28,
    /// Sequence error.
    Sequence = 0x29,
    /// DAQ configuration not valid.
    DaqConfig = 0x2A,
    /// Memory overflow (the static DAQ pool is exhausted).
    MemoryOverflow = 0x30,
    /// Generic error (the application rejected a parameter set as unstable or inconsistent).
    Generic = 0x31,
    /// Verify error (not used).
    Verify = 0x32,
    /// Resource temporarily not accessible (a calibration store while the controller runs).
    ResourceTemporaryNotAccessible = 0x33,
}

impl ErrorCode {
    /// The code as sent on the bus.
    #[must_use]
    pub const fn code(self) -> u8 {
        self as u8
    }
}
