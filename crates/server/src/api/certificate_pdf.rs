//! A certificate's [`Sheet`] as a one-page A4 PDF. The text is set in the
//! PDF's built-in Helvetica (no font embedded, and any reader extracts it)
//! in WinAnsi encoding, which has °, ±, µ and ²; σ, which it lacks, is
//! set in the built-in Symbol font, whose `s` is σ. Anything else outside
//! WinAnsi is written as `?`. Everything is placed at fixed positions sized
//! so the 24 parameters and every fact fit the one page.

use pdf_writer::{Content, Finish, Name, Pdf, Rect, Ref, Str, TextStr};

use super::certificate_sheet::{Sheet, DRAFT, HEADS};

/// A4 in points.
const WIDTH: f32 = 595.0;
const HEIGHT: f32 = 842.0;
const LEFT: f32 = 40.0;
const RIGHT: f32 = WIDTH - 40.0;

const REGULAR: Name<'static> = Name(b"F1");
const BOLD: Name<'static> = Name(b"F2");
const SYMBOL: Name<'static> = Name(b"F3");

/// Left edge of each column of the parameter table.
const COLUMNS: [f32; 10] = [
    LEFT, 132.0, 196.0, 240.0, 290.0, 340.0, 388.0, 436.0, 484.0, 528.0,
];

/// The PDF of `sheet`.
pub fn render(sheet: &Sheet) -> Vec<u8> {
    let mut pdf = Pdf::new();
    let (catalog, pages, page, contents, info) = (
        Ref::new(1),
        Ref::new(2),
        Ref::new(3),
        Ref::new(4),
        Ref::new(5),
    );
    let fonts = [
        (REGULAR, Ref::new(6), "Helvetica"),
        (BOLD, Ref::new(7), "Helvetica-Bold"),
        (SYMBOL, Ref::new(8), "Symbol"),
    ];
    pdf.catalog(catalog).pages(pages);
    pdf.pages(pages).kids([page]).count(1);
    let mut p = pdf.page(page);
    p.media_box(Rect::new(0.0, 0.0, WIDTH, HEIGHT));
    p.parent(pages);
    p.contents(contents);
    {
        let mut resources = p.resources();
        let mut font_refs = resources.fonts();
        for (name, id, _) in fonts {
            font_refs.pair(name, id);
        }
    }
    p.finish();
    for (name, id, base) in fonts {
        let mut font = pdf.type1_font(id);
        font.base_font(Name(base.as_bytes()));
        // Symbol has its own built-in encoding.
        if name != SYMBOL {
            font.encoding_predefined(Name(b"WinAnsiEncoding"));
        }
    }
    let title = match &sheet.number {
        Some(n) => format!("Calibration certificate {n}"),
        None => "Calibration certificate (draft)".to_string(),
    };
    pdf.document_info(info)
        .title(TextStr(&title))
        .producer(TextStr(concat!("sinscal ", env!("CARGO_PKG_VERSION"))));
    let body = Page::new().draw(sheet);
    pdf.stream(contents, &body);
    pdf.finish()
}

/// The page's content stream, written top to bottom.
struct Page {
    c: Content,
    /// The baseline of the next line, from the page's top.
    y: f32,
}

impl Page {
    fn new() -> Page {
        Page {
            c: Content::new(),
            y: 56.0,
        }
    }

    fn draw(mut self, sheet: &Sheet) -> Vec<u8> {
        if sheet.number.is_none() {
            self.watermark();
        }
        self.text(LEFT, BOLD, 16.0, "Calibration certificate");
        match &sheet.number {
            Some(n) => self.text(380.0, BOLD, 14.0, &format!("No. {n}")),
            None => {
                self.c.set_fill_rgb(0.75, 0.0, 0.0);
                self.text(330.0, BOLD, 11.0, DRAFT);
                self.c.set_fill_gray(0.0);
            }
        }
        self.y += 16.0;
        let issued = sheet.issued.as_deref().unwrap_or("not issued");
        self.text(380.0, REGULAR, 9.0, &format!("Issued {issued}"));
        self.y += 8.0;
        self.rule(self.y);
        self.y += 16.0;
        for (label, value) in &sheet.facts {
            self.text(LEFT, BOLD, 8.5, label);
            self.text(132.0, REGULAR, 8.5, value);
            self.y += 11.5;
        }
        self.y += 4.0;
        self.approval(sheet);
        self.y += 20.0;
        self.text(LEFT, BOLD, 10.0, "Parameters (1σ from the estimator)");
        self.text(
            300.0,
            REGULAR,
            7.5,
            &format!(
                "Repeat.: SD over the unit's {} run(s) up to this one",
                sheet.repeatability_runs
            ),
        );
        self.y += 14.0;
        for (x, head) in COLUMNS.iter().zip(HEADS) {
            self.text(*x, BOLD, 7.5, head);
        }
        self.y += 3.5;
        self.rule(self.y);
        self.y += 10.0;
        for row in &sheet.rows {
            let failed = row.check == "fail" || row.repeat_check == "fail";
            if failed {
                self.c.set_fill_rgb(0.75, 0.0, 0.0);
            }
            for (x, cell) in COLUMNS.iter().zip(row.cells()) {
                self.text(*x, REGULAR, 7.5, cell);
            }
            if failed {
                self.c.set_fill_gray(0.0);
            }
            self.y += 10.5;
        }
        self.rule(self.y - 7.0);
        self.y += 8.0;
        for note in notes(sheet) {
            self.text(LEFT, REGULAR, 7.0, &note);
            self.y += 9.5;
        }
        self.c.finish().to_vec()
    }

    /// Who approved, in what role, when; or that it is a draft.
    fn approval(&mut self, sheet: &Sheet) {
        let top = self.y;
        self.y += 12.0;
        match &sheet.approval {
            Some((who, role, when)) => {
                self.text(LEFT + 8.0, BOLD, 9.0, "Approved");
                self.text(132.0, REGULAR, 9.0, &format!("by {who} ({role}), {when}"));
            }
            None => {
                self.c.set_fill_rgb(0.75, 0.0, 0.0);
                self.text(LEFT + 8.0, BOLD, 9.0, "DRAFT");
                self.c.set_fill_gray(0.0);
                self.text(
                    132.0,
                    REGULAR,
                    9.0,
                    "Not approved: not a valid certificate. An engineer or admin approves an accepted result.",
                );
            }
        }
        self.y += 6.0;
        self.c.set_line_width(0.6);
        self.c
            .rect(LEFT, HEIGHT - self.y, RIGHT - LEFT, self.y - top);
        self.c.stroke();
    }

    /// "DRAFT" across the page in light grey, under everything else.
    fn watermark(&mut self) {
        // 45°.
        let (cos, sin) = (
            std::f32::consts::FRAC_1_SQRT_2,
            std::f32::consts::FRAC_1_SQRT_2,
        );
        self.c.set_fill_gray(0.88);
        self.c.begin_text();
        self.c.set_font(BOLD, 110.0);
        self.c.set_text_matrix([cos, sin, -sin, cos, 150.0, 250.0]);
        self.c.show(Str(b"DRAFT"));
        self.c.end_text();
        self.c.set_fill_gray(0.0);
    }

    fn rule(&mut self, y: f32) {
        self.c.set_line_width(0.5);
        self.c.move_to(LEFT, HEIGHT - y);
        self.c.line_to(RIGHT, HEIGHT - y);
        self.c.stroke();
    }

    /// `text` at `x` on the current line, σ in Symbol.
    fn text(&mut self, x: f32, font: Name<'static>, size: f32, text: &str) {
        self.c.begin_text();
        self.c.next_line(x, HEIGHT - self.y);
        for (i, run) in text.split('σ').enumerate() {
            if i > 0 {
                self.c.set_font(SYMBOL, size);
                self.c.show(Str(b"s"));
            }
            if !run.is_empty() {
                self.c.set_font(font, size);
                self.c.show(Str(&win_ansi(run)));
            }
        }
        self.c.end_text();
    }
}

fn notes(sheet: &Sheet) -> Vec<String> {
    let mut notes = vec![
        "Sign convention, units and the error model: sinscal's contract, SPEC §2. Limits are the product type's; \"-\": none set.".to_string(),
        "Check: the result against |value| and σ limits as the verdict judged it; Repeat.: the SD over runs against the product's max_repeatability.".to_string(),
    ];
    if !sheet.superseded.is_empty() {
        notes.push(format!(
            "Earlier results of this run were certified as: {}",
            sheet.superseded.join("; ")
        ));
    }
    notes
}

/// `text` in WinAnsi (Windows-1252): ASCII, and the Latin-1 and other
/// characters the encoding has that a certificate uses.
fn win_ansi(text: &str) -> Vec<u8> {
    text.chars()
        .map(|ch| match ch {
            ' '..='~' => ch as u8,
            '–' => 0x96,
            '—' => 0x97,
            '\u{a0}'..='\u{ff}' => ch as u32 as u8,
            _ => b'?',
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_written_in_win_ansi() {
        assert_eq!(
            win_ansi("±1 µg, 25 °C — x²"),
            b"\xb11 \xb5g, 25 \xb0C \x97 x\xb2"
        );
        assert_eq!(win_ansi("√"), b"?");
    }
}
