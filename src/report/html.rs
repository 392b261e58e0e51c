//! `index.html`: every table, plot and side-by-side picture of a report
//! folder on one page, with the command that regenerates each figure.

use super::table::{Table, escape_html};

/// A figure: an SVG or PNG file in the report folder.
#[derive(Clone, Debug)]
pub struct Figure {
    /// File name relative to the page.
    pub file: String,
    /// Caption.
    pub caption: String,
}

/// One row of pictures: a render and its reference (shown on hover), the difference and the FLIP map.
#[derive(Clone, Debug)]
pub struct PictureRow {
    /// Row title.
    pub title: String,
    /// Label of the render.
    pub render_label: String,
    /// The render (relative path).
    pub render: String,
    /// Label of the reference.
    pub reference_label: String,
    /// The reference (relative path).
    pub reference: String,
    /// Difference picture (relative path) and its caption.
    pub difference: (String, String),
    /// FLIP map (relative path) and its caption.
    pub flip: (String, String),
    /// Metrics shown under the row.
    pub metrics: String,
}

/// One piece of a section, in page order; each is followed by the command that regenerates it.
#[derive(Clone, Debug)]
pub enum Block {
    /// A table.
    Table(Table),
    /// Plots or pictures side by side (wrapping to the page width).
    Figures(Vec<Figure>),
    /// A row of pictures: render (flips to the reference on hover), reference, difference, FLIP map.
    Pictures(PictureRow),
}

/// A section of the page.
#[derive(Clone, Debug, Default)]
pub struct Section {
    /// Anchor id.
    pub id: String,
    /// Heading.
    pub title: String,
    /// Introductory text.
    pub intro: String,
    /// Tables, figures and picture rows, in page order.
    pub blocks: Vec<Block>,
    /// The command that regenerates this section.
    pub command: String,
    /// The JSON and Markdown files of the section (relative paths).
    pub data: Vec<String>,
}

const STYLE: &str = "body{font-family:sans-serif;margin:24px;max-width:1500px;color:#222}\
table{border-collapse:collapse;margin:12px 0;font-size:13px}\
caption{font-weight:bold;text-align:left;padding:4px 0}\
th,td{border:1px solid #ccc;padding:3px 7px}td{text-align:right;font-variant-numeric:tabular-nums}\
thead th{background:#eee}tbody th{text-align:left;font-weight:normal}\
p.note{font-size:12px;color:#555;max-width:1100px}\
figure{margin:16px 0}figure img{max-width:100%;border:1px solid #ddd}\
code{background:#f4f4f4;padding:2px 5px}\
.cmd{font-size:12px;color:#333}\
.figs{display:flex;gap:16px;align-items:flex-start;flex-wrap:wrap}.figs figure{margin:8px 0;width:min-content}.figs img{max-width:none}\
.pics{display:flex;gap:10px;align-items:flex-start;flex-wrap:wrap}\
.pics figure{margin:0;width:256px}.pics figcaption{font-size:13px}\
.pics img{width:256px;image-rendering:pixelated}\
.flip img.b{display:none}.flip:hover img.a{display:none}.flip:hover img.b{display:inline}\
nav a{margin-right:14px}";

/// The whole page.
pub fn page(title: &str, header: &[Table], sections: &[Section]) -> String {
    let mut o = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{t}</h1>\n<nav>",
        t = escape_html(title)
    );
    for s in sections {
        o.push_str(&format!("<a href=\"#{}\">{}</a>", escape_html(&s.id), escape_html(&s.title)));
    }
    o.push_str("</nav>\n");
    for t in header {
        o.push_str(&t.to_html());
    }
    for s in sections {
        o.push_str(&section(s));
    }
    o.push_str("</body>\n</html>\n");
    o
}

fn command(cmd: &str) -> String {
    format!("<p class=\"cmd\">Regenerate: <code>{}</code></p>\n", escape_html(cmd))
}

fn section(s: &Section) -> String {
    let mut o = format!("<section id=\"{}\">\n<h2>{}</h2>\n", escape_html(&s.id), escape_html(&s.title));
    if !s.intro.is_empty() {
        o.push_str(&format!("<p>{}</p>\n", escape_html(&s.intro)));
    }
    if !s.data.is_empty() {
        o.push_str("<p class=\"cmd\">Data: ");
        let links: Vec<String> = s.data.iter().map(|d| format!("<a href=\"{0}\">{0}</a>", escape_html(d))).collect();
        o.push_str(&links.join(", "));
        o.push_str("</p>\n");
    }
    for b in &s.blocks {
        match b {
            Block::Table(t) => {
                o.push_str(&t.to_html());
                o.push_str(&command(&s.command));
            }
            Block::Figures(fs) => {
                o.push_str("<div class=\"figs\">\n");
                for f in fs {
                    o.push_str(&format!(
                        "<figure><img src=\"{}\" alt=\"{c}\"><figcaption>{c}</figcaption>{}</figure>\n",
                        escape_html(&f.file),
                        command(&s.command),
                        c = escape_html(&f.caption)
                    ));
                }
                o.push_str("</div>\n");
            }
            Block::Pictures(p) => o.push_str(&pictures(p, &s.command)),
        }
    }
    o.push_str("</section>\n");
    o
}

fn pictures(p: &PictureRow, cmd: &str) -> String {
    let mut o = format!("<h3>{}</h3>\n<div class=\"pics\">\n", escape_html(&p.title));
    o.push_str(&format!(
        "<figure class=\"flip\"><img class=\"a\" src=\"{r}\" alt=\"{rl}\"><img class=\"b\" src=\"{f}\" alt=\"{fl}\">\
         <figcaption>{rl} (hover: {fl})</figcaption></figure>\n",
        r = escape_html(&p.render),
        rl = escape_html(&p.render_label),
        f = escape_html(&p.reference),
        fl = escape_html(&p.reference_label)
    ));
    for (file, cap) in [(&p.reference, &p.reference_label), (&p.difference.0, &p.difference.1), (&p.flip.0, &p.flip.1)]
    {
        o.push_str(&format!(
            "<figure><img src=\"{}\" alt=\"{c}\"><figcaption>{c}</figcaption></figure>\n",
            escape_html(file),
            c = escape_html(cap)
        ));
    }
    o.push_str(&format!("</div>\n<p class=\"note\">{}</p>\n", escape_html(&p.metrics)));
    o.push_str(&command(cmd));
    o
}

/// Every `href` and `src` target of a page (for checking that they exist).
pub fn links(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["href=\"", "src=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            if let Some(j) = rest.find('"') {
                out.push(
                    rest[..j].replace("&amp;", "&").replace("&quot;", "\"").replace("&lt;", "<").replace("&gt;", ">"),
                );
                rest = &rest[j..];
            }
        }
    }
    out
}
