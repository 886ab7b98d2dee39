//! The CDR payload of a ROS 2 `sensor_msgs/msg/Imu`, decoded by hand: the
//! message is fixed apart from its frame id, and a code generator or an
//! IDL crate would be more than the 37 doubles it holds.
//!
//! Layout (OMG CDR, XCDR1 as ROS 2's middleware writes it): a 4-byte
//! encapsulation header (`00 00` big endian, `00 01` little endian, two
//! option bytes), then, aligned relative to the byte after that header —
//!
//! - `std_msgs/Header`: `builtin_interfaces/Time stamp` (int32 sec, uint32
//!   nanosec), `string frame_id` (uint32 length counting its NUL, bytes);
//! - padding to 8, then 37 float64: orientation (x, y, z, w),
//!   orientation_covariance\[9\], angular_velocity (x, y, z),
//!   angular_velocity_covariance\[9\], linear_acceleration (x, y, z),
//!   linear_acceleration_covariance\[9\].

/// Why a payload is not an Imu message.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CdrError {
    /// The payload ends before a field: what was being read, the bytes it
    /// needed (counted from the payload's start) and the bytes there are.
    #[error("truncated payload: {field} needs {need} bytes, the message has {have}")]
    Truncated {
        field: &'static str,
        need: usize,
        have: usize,
    },
    /// An encapsulation other than plain CDR (XCDR2 and parameter lists
    /// align and delimit differently; a ROS 2 Imu is never written so).
    #[error("encapsulation {0:#06x} is not plain CDR (0x0000 or 0x0001)")]
    Encapsulation(u16),
    #[error("frame_id is not UTF-8")]
    FrameId,
}

/// The fields of an Imu message the importer uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Imu {
    pub stamp_sec: i32,
    pub stamp_nanosec: u32,
    pub frame_id: String,
    pub angular_velocity: [f64; 3],
    /// Element 0 is −1 when the sender has no angular rate (REP 145).
    pub angular_velocity_covariance_0: f64,
    pub linear_acceleration: [f64; 3],
    pub linear_acceleration_covariance_0: f64,
}

/// Bytes of the encapsulation header.
const ENCAPSULATION: usize = 4;

/// A cursor over the body (the payload after the encapsulation header),
/// where CDR alignment is counted from.
struct Body<'a> {
    bytes: &'a [u8],
    at: usize,
    little: bool,
}

impl<'a> Body<'a> {
    fn take(&mut self, n: usize, align: usize, field: &'static str) -> Result<&'a [u8], CdrError> {
        let start = self.at.next_multiple_of(align);
        // saturating: a corrupt length must read as truncated, not wrap
        let end = start.saturating_add(n);
        if end > self.bytes.len() {
            return Err(CdrError::Truncated {
                field,
                need: ENCAPSULATION.saturating_add(end),
                have: ENCAPSULATION + self.bytes.len(),
            });
        }
        self.at = end;
        Ok(&self.bytes[start..end])
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        let b: [u8; 4] = self.take(4, 4, field)?.try_into().expect("4 bytes");
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64s<const N: usize>(&mut self, field: &'static str) -> Result<[f64; N], CdrError> {
        let b = self.take(8 * N, 8, field)?;
        Ok(std::array::from_fn(|k| {
            let v: [u8; 8] = b[8 * k..8 * k + 8].try_into().expect("8 bytes");
            if self.little {
                f64::from_le_bytes(v)
            } else {
                f64::from_be_bytes(v)
            }
        }))
    }
}

/// Decodes one `sensor_msgs/msg/Imu` payload. Bytes after the message are
/// ignored: the CDR stream may be padded to 4 bytes.
pub fn decode_imu(payload: &[u8]) -> Result<Imu, CdrError> {
    if payload.len() < ENCAPSULATION {
        return Err(CdrError::Truncated {
            field: "encapsulation header",
            need: ENCAPSULATION,
            have: payload.len(),
        });
    }
    let kind = u16::from_be_bytes([payload[0], payload[1]]);
    let little = match kind {
        0x0000 => false,
        0x0001 => true,
        other => return Err(CdrError::Encapsulation(other)),
    };
    let mut body = Body {
        bytes: &payload[ENCAPSULATION..],
        at: 0,
        little,
    };
    let stamp_sec = body.u32("header.stamp.sec")? as i32;
    let stamp_nanosec = body.u32("header.stamp.nanosec")?;
    let len = body.u32("header.frame_id length")? as usize;
    let text = body.take(len, 1, "header.frame_id")?;
    // The length counts a terminating NUL; a writer that leaves it out
    // (length 0 for an empty id) is read all the same.
    let text = text.strip_suffix(&[0]).unwrap_or(text);
    let frame_id = std::str::from_utf8(text)
        .map_err(|_| CdrError::FrameId)?
        .to_string();
    let _orientation: [f64; 4] = body.f64s("orientation")?;
    let _: [f64; 9] = body.f64s("orientation_covariance")?;
    let angular_velocity = body.f64s("angular_velocity")?;
    let w_cov: [f64; 9] = body.f64s("angular_velocity_covariance")?;
    let linear_acceleration = body.f64s("linear_acceleration")?;
    let f_cov: [f64; 9] = body.f64s("linear_acceleration_covariance")?;
    Ok(Imu {
        stamp_sec,
        stamp_nanosec,
        frame_id,
        angular_velocity,
        angular_velocity_covariance_0: w_cov[0],
        linear_acceleration,
        linear_acceleration_covariance_0: f_cov[0],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A big-endian message with a frame id whose length makes the
    /// doubles need padding: the header's flag and the alignment both
    /// matter.
    fn big_endian(frame: &str) -> Vec<u8> {
        let mut b = vec![0, 0, 0, 0];
        b.extend_from_slice(&7i32.to_be_bytes());
        b.extend_from_slice(&500u32.to_be_bytes());
        b.extend_from_slice(&(frame.len() as u32 + 1).to_be_bytes());
        b.extend_from_slice(frame.as_bytes());
        b.push(0);
        while (b.len() - 4) % 8 != 0 {
            b.push(0xAA);
        }
        for k in 0..37 {
            b.extend_from_slice(&(k as f64 * 0.5).to_be_bytes());
        }
        b
    }

    #[test]
    fn a_big_endian_message_is_read_after_its_padding() {
        let imu = decode_imu(&big_endian("imu_link")).expect("decodes");
        assert_eq!((imu.stamp_sec, imu.stamp_nanosec), (7, 500));
        assert_eq!(imu.frame_id, "imu_link");
        // orientation 0..4, its covariance 4..13, angular velocity 13..16
        assert_eq!(imu.angular_velocity, [6.5, 7.0, 7.5]);
        assert_eq!(imu.angular_velocity_covariance_0, 8.0);
        assert_eq!(imu.linear_acceleration, [12.5, 13.0, 13.5]);
        assert_eq!(imu.linear_acceleration_covariance_0, 14.0);
    }

    #[test]
    fn a_short_payload_names_the_field_it_lacks() {
        let full = big_endian("imu");
        let err = decode_imu(&full[..full.len() - 1]).expect_err("short");
        assert_eq!(
            err,
            CdrError::Truncated {
                field: "linear_acceleration_covariance",
                need: full.len(),
                have: full.len() - 1
            }
        );
        let err = decode_imu(&full[..14]).expect_err("short");
        assert!(matches!(
            err,
            CdrError::Truncated {
                field: "header.frame_id length",
                ..
            }
        ));
    }

    #[test]
    fn other_encapsulations_are_refused() {
        let mut b = big_endian("x");
        b[1] = 0x11;
        assert_eq!(decode_imu(&b), Err(CdrError::Encapsulation(0x0011)));
    }
}
