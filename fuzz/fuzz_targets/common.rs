//! What every target shares: the trailing CRC-32 every record format ends with, recomputed
//! over the bytes before it, so that mutations reach past the checksum.

use shared::trace::Crc32;

/// `bytes` with its last four bytes set to the CRC-32 (IEEE, little-endian) of the rest.
pub fn sealed(mut bytes: Vec<u8>) -> Vec<u8> {
    if bytes.len() >= 4 {
        let body = bytes.len() - 4;
        let mut crc = Crc32::new();
        crc.update(&bytes[..body]);
        bytes[body..].copy_from_slice(&crc.finish().to_le_bytes());
    }
    bytes
}
