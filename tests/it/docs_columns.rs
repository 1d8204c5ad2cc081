//! `docs/reference.md`'s per-sample column list is the table the writers
//! use (`output::columns`). Run with `IMPACTMC_BLESS=1` to rewrite the list
//! after changing the table.

use std::path::Path;

const BEGIN: &str = "<!-- columns: begin -->\n";
const END: &str = "<!-- columns: end -->";

#[test]
fn reference_lists_the_columns_the_writers_use() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/reference.md");
    let doc = std::fs::read_to_string(&path).expect("docs/reference.md");
    let a = doc.find(BEGIN).expect("the column list's begin marker") + BEGIN.len();
    let b = doc[a..].find(END).expect("the column list's end marker") + a;
    let want = impactmc::output::columns::reference_markdown();
    if doc[a..b] == want {
        return;
    }
    if std::env::var_os("IMPACTMC_BLESS").is_some() {
        let fixed = format!("{}{want}{}", &doc[..a], &doc[b..]);
        std::fs::write(&path, fixed).expect("rewrite docs/reference.md");
        return;
    }
    panic!(
        "docs/reference.md's column list differs from output::columns; \
         rerun with IMPACTMC_BLESS=1 to rewrite it:\n{want}"
    );
}
