//! A plain table (title, header, rows of text cells) that each typed report is
//! turned into once, then written as Markdown or HTML.

/// A table of text cells.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Caption.
    pub title: String,
    /// Column headers.
    pub header: Vec<String>,
    /// Rows (each as long as the header).
    pub rows: Vec<Vec<String>>,
    /// Lines printed under the table.
    pub notes: Vec<String>,
}

impl Table {
    /// GitHub-flavoured Markdown (first column left-aligned, the others right-aligned).
    pub fn to_markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let mut o = String::new();
        if !self.title.is_empty() {
            o.push_str(&format!("### {}\n\n", self.title));
        }
        o.push_str(&format!("| {} |\n", self.header.iter().map(|h| esc(h)).collect::<Vec<_>>().join(" | ")));
        let align: Vec<&str> = (0..self.header.len()).map(|i| if i == 0 { "---" } else { "---:" }).collect();
        o.push_str(&format!("|{}|\n", align.join("|")));
        for r in &self.rows {
            o.push_str(&format!("| {} |\n", r.iter().map(|c| esc(c)).collect::<Vec<_>>().join(" | ")));
        }
        for n in &self.notes {
            o.push_str(&format!("\n{n}\n"));
        }
        o
    }

    /// An HTML `<table>` with a caption, and the notes as paragraphs.
    pub fn to_html(&self) -> String {
        let mut o = String::from("<table>\n");
        if !self.title.is_empty() {
            o.push_str(&format!("<caption>{}</caption>\n", escape_html(&self.title)));
        }
        o.push_str("<thead><tr>");
        for h in &self.header {
            o.push_str(&format!("<th>{}</th>", escape_html(h)));
        }
        o.push_str("</tr></thead>\n<tbody>\n");
        for r in &self.rows {
            o.push_str("<tr>");
            for (i, c) in r.iter().enumerate() {
                let tag = if i == 0 { "th" } else { "td" };
                o.push_str(&format!("<{tag}>{}</{tag}>", escape_html(c)));
            }
            o.push_str("</tr>\n");
        }
        o.push_str("</tbody>\n</table>\n");
        for n in &self.notes {
            o.push_str(&format!("<p class=\"note\">{}</p>\n", escape_html(n)));
        }
        o
    }
}

/// Escape `&`, `<`, `>` and `"` for HTML text and attributes.
pub fn escape_html(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A figure with about four significant digits, without exponent for everyday magnitudes.
pub fn fmt_num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e7).contains(&a) {
        format!("{v:.2e}")
    } else if a >= 1000.0 {
        format!("{v:.0}")
    } else if a >= 100.0 {
        format!("{v:.1}")
    } else if a >= 10.0 {
        format!("{v:.2}")
    } else if a >= 1.0 {
        format!("{v:.3}")
    } else {
        format!("{v:.4}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_and_html_have_every_cell() {
        let t = Table {
            title: "T".into(),
            header: vec!["a".into(), "b|c".into()],
            rows: vec![vec!["x<y".into(), "1".into()]],
            notes: vec!["n".into()],
        };
        let md = t.to_markdown();
        assert!(md.contains("| a | b\\|c |\n|---|---:|\n| x<y | 1 |"));
        let html = t.to_html();
        assert!(html.contains("<th>x&lt;y</th><td>1</td>"));
        assert_eq!(fmt_num(1064.87), "1065");
        assert_eq!(fmt_num(0.1073), "0.1073");
        assert_eq!(fmt_num(2.5e-5), "2.50e-5");
    }
}
