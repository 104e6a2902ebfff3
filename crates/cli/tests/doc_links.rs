//! The docs stand alone: every relative link in README.md, docs/*.md and the crate READMEs
//! names a file of the repository (and, for `#anchor`s, a heading of that file), and no text
//! points outside the repository.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// README.md, docs/*.md and crates/*/README.md.
fn markdown_files() -> Vec<PathBuf> {
    let root = repo();
    let mut files = vec![root.join("README.md")];
    let mut in_dir = |dir: PathBuf, want: &dyn Fn(&Path) -> bool| {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            return;
        };
        let mut found: Vec<PathBuf> = entries
            .map(|e| e.unwrap().path())
            .filter(|p| want(p))
            .collect();
        found.sort();
        files.extend(found);
    };
    in_dir(root.join("docs"), &|p| {
        p.extension().is_some_and(|e| e == "md")
    });
    in_dir(root.join("crates"), &|p| p.join("README.md").is_file());
    files
        .into_iter()
        .map(|p| if p.is_dir() { p.join("README.md") } else { p })
        .collect()
}

/// The lines outside fenced code blocks, with inline code spans removed.
fn prose(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let mut kept = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                kept.push_str(part);
            }
        }
        out.push(kept);
    }
    out
}

/// Every `[text](target)` and `![alt](target)` target.
fn link_targets(text: &str) -> Vec<String> {
    let mut targets = Vec::new();
    for line in prose(text) {
        let mut rest = line.as_str();
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            let end = rest.find(')').unwrap_or(rest.len());
            let target = rest[..end].split_whitespace().next().unwrap_or("");
            targets.push(target.to_string());
            rest = &rest[end..];
        }
    }
    targets
}

/// GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens, repeats
/// numbered.
fn anchors(text: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let title = line.trim_start_matches('#').trim();
        let slug: String = title
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let mut unique = slug.clone();
        let mut n = 1;
        while seen.contains(&unique) {
            unique = format!("{slug}-{n}");
            n += 1;
        }
        seen.insert(unique);
    }
    seen
}

#[test]
fn slugs_are_githubs() {
    let a = anchors(
        "# Title\n## 4. Motor and driver model\n## `multistep plan`\n## seed 000\n## seed 000\n",
    );
    for want in [
        "title",
        "4-motor-and-driver-model",
        "multistep-plan",
        "seed-000",
        "seed-000-1",
    ] {
        assert!(a.contains(want), "{want}: {a:?}");
    }
    assert_eq!(
        link_targets(
            "see [a](x.md#y) and `[b](not-a-link)`, ![c](img.png \"t\")\n```\n[d](e)\n```"
        ),
        ["x.md#y", "img.png"]
    );
}

#[test]
fn every_relative_link_resolves() {
    let root = repo();
    let files = markdown_files();
    assert!(files.len() >= 10, "{files:?}");
    assert!(files.iter().any(|f| f.ends_with("docs/DESIGN.md")));
    let mut broken = Vec::new();
    let mut checked = 0;
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let name = file.strip_prefix(&root).unwrap().display().to_string();
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let resolved = if path.is_empty() {
                file.clone()
            } else {
                file.parent().unwrap().join(path)
            };
            let Ok(resolved) = resolved.canonicalize() else {
                broken.push(format!("{name}: {target}: no such file"));
                continue;
            };
            if !resolved.starts_with(&root) {
                broken.push(format!("{name}: {target}: outside the repository"));
                continue;
            }
            if let Some(anchor) = anchor {
                let is_md = resolved.extension().is_some_and(|e| e == "md");
                let text = std::fs::read_to_string(&resolved).unwrap_or_default();
                if is_md && !anchors(&text).contains(anchor) {
                    broken.push(format!("{name}: {target}: no heading #{anchor}"));
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} links found");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// Text that points outside the repository or at how the work was organised.
const OUTSIDE_WORDING: [&str; 7] = [
    "../shared",
    "engineers'",
    "seeds/",
    "drafted for the readme",
    "issue's",
    "the issue ",
    "issue #",
];

#[test]
fn no_text_points_outside_the_repository() {
    let root = repo();
    let mut files = markdown_files();
    let mut stack = vec![root.join("crates"), root.join("examples")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if name != "target" && name != "node_modules" {
                    stack.push(p);
                }
            } else if [".rs", ".toml", ".v", ".mjs", ".js", ".md"]
                .iter()
                .any(|x| name.ends_with(x))
            {
                files.push(p);
            }
        }
    }
    let this_file = Path::new(file!()).file_name().unwrap();
    let mut found = Vec::new();
    for file in files.iter().filter(|f| f.file_name() != Some(this_file)) {
        let text = std::fs::read_to_string(file).unwrap().to_lowercase();
        for (n, line) in text.lines().enumerate() {
            let numbered_issue = line
                .match_indices("issue ")
                .any(|(i, _)| line[i + 6..].starts_with(|c: char| c.is_ascii_digit()));
            if numbered_issue || OUTSIDE_WORDING.iter().any(|w| line.contains(w)) {
                let name = file.strip_prefix(&root).unwrap().display();
                found.push(format!("{name}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "wording to fix:\n{}", found.join("\n"));
}
