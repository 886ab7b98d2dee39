//! A text log read line by line with each line's number, the shape the
//! text importers (`psins`, `imu_tk`) share: they skip different lines and
//! name the line in every refusal.

use std::io::{self, BufRead};

/// The lines of a text stream, one held at a time.
pub(crate) struct TextLines {
    reader: Box<dyn BufRead>,
    /// 1-based number of the line held (0 before the first).
    pub line: u64,
    /// The line held, with its line end.
    pub text: String,
}

impl TextLines {
    pub fn new(reader: Box<dyn BufRead>) -> Self {
        TextLines {
            reader,
            line: 0,
            text: String::new(),
        }
    }

    /// Moves to the next line whose trimmed text `skip` does not pass
    /// over; false at the end of the stream.
    pub fn advance(&mut self, skip: impl Fn(&str) -> bool) -> io::Result<bool> {
        loop {
            self.text.clear();
            if self.reader.read_line(&mut self.text)? == 0 {
                return Ok(false);
            }
            self.line += 1;
            if !skip(self.text.trim()) {
                return Ok(true);
            }
        }
    }
}
