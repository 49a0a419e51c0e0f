//! Reads Mitsuba XML into a plain element tree: `$param` substitution
//! (`-D key=value` first, then `<default>`), `<include>` spliced in, and the
//! 0.5 → 3 upgrade applied per file. Every element keeps its file, line and
//! column, so later errors and warnings can name them.

use super::resolver::Resolver;
use super::upgrade;
use crate::echo::echo;
use crate::location::{line_column, read_regular_file};
use crate::scene::SceneError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Where an element is written.
#[derive(Clone, Debug)]
pub(super) struct Loc {
    pub file: Rc<PathBuf>,
    pub line: usize,
    pub column: usize,
}

impl Loc {
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.to_path_buf(),
            location: Some((self.line, self.column)),
            message: message.into(),
        }
    }

    /// The folder relative file names of this element are resolved in.
    pub fn dir(&self) -> &Path {
        self.file.parent().unwrap_or(Path::new("."))
    }
}

impl std::fmt::Display for Loc {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// One XML element, its attributes substituted.
#[derive(Clone, Debug)]
pub(super) struct Elem {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Elem>,
    pub loc: Loc,
}

impl Elem {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn need(&self, name: &str) -> Result<&str, SceneError> {
        self.attr(name).ok_or_else(|| {
            self.loc
                .error(format!("<{}> needs the attribute `{name}`", self.tag))
        })
    }

    /// `type`, for messages and dispatch; empty when absent.
    pub fn kind(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// How a message names this element: `<bsdf type="diffuse">`.
    pub fn describe(&self) -> String {
        match (self.attr("type"), self.attr("name")) {
            (Some(t), _) => format!("<{} type=\"{t}\">", self.tag),
            (None, Some(n)) => format!("<{} name=\"{n}\">", self.tag),
            _ => format!("<{}>", self.tag),
        }
    }
}

/// Elements nest at most this deep: the tree is walked recursively, and a
/// scene needs a handful of levels.
const MAX_DEPTH: usize = 64;

/// Includes nest at most this deep (a file including itself is refused
/// before that, by name).
const MAX_INCLUDE_DEPTH: usize = 32;

/// Reads a scene file into its `<scene>` element.
pub(super) struct Reader {
    params: HashMap<String, String>,
    /// The files being read, outermost first: an include cycle is refused.
    stack: Vec<PathBuf>,
    pub files: Vec<PathBuf>,
    /// Where relative file names are looked for, `<path>`s included.
    pub resolver: Resolver,
}

impl Reader {
    /// A reader of the scene file `scene_file` (its folder is searched for
    /// file names last).
    pub fn new(defines: &[(String, String)], scene_file: &Path) -> Self {
        Self {
            params: defines.iter().cloned().collect(),
            stack: Vec::new(),
            files: Vec::new(),
            resolver: Resolver::new(scene_file),
        }
    }

    /// Parses `text` (the file at `path`) into its root `<scene>`.
    pub fn scene(&mut self, text: &str, path: &Path) -> Result<Elem, SceneError> {
        self.stack.push(path.to_path_buf());
        self.files.push(path.to_path_buf());
        let file = Rc::new(path.to_path_buf());
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            let p = e.pos();
            SceneError {
                file: path.to_path_buf(),
                location: Some((p.row as usize, p.col as usize)),
                message: format!("malformed XML: {e}"),
            }
        })?;
        let root = doc.root_element();
        let loc = location(&doc, root, &file);
        if root.tag_name().name() != "scene" {
            return Err(loc.error(format!(
                "the root element is <{}>; a Mitsuba scene is <scene version=\"...\">",
                root.tag_name().name()
            )));
        }
        let version = self.version(root, &loc)?;
        self.defaults(&doc, root, &file)?;
        let children = self.children(&doc, root, &file, version, 0)?;
        self.stack.pop();
        Ok(Elem {
            tag: "scene".into(),
            attrs: vec![],
            children,
            loc,
        })
    }

    fn version(&self, root: roxmltree::Node, loc: &Loc) -> Result<(u32, u32), SceneError> {
        let v = root.attribute("version").ok_or_else(|| {
            loc.error("<scene> needs a `version` (e.g. \"3.0.0\"); it decides which upgrades apply")
        })?;
        let mut parts = v.split('.').map(|p| p.trim().parse::<u32>());
        match (parts.next(), parts.next()) {
            (Some(Ok(major)), Some(Ok(minor))) => Ok((major, minor)),
            _ => Err(loc.error(format!(
                "`version`: expected MAJOR.MINOR.PATCH, found {}",
                echo(v)
            ))),
        }
    }

    /// `<default name value>` at the top of a file: parameters the command
    /// line did not set.
    fn defaults(
        &mut self,
        doc: &roxmltree::Document,
        root: roxmltree::Node,
        file: &Rc<PathBuf>,
    ) -> Result<(), SceneError> {
        for node in root.children().filter(|n| n.has_tag_name("default")) {
            let loc = location(doc, node, file);
            let name = node
                .attribute("name")
                .ok_or_else(|| loc.error("<default> needs the attribute `name`"))?;
            let value = node
                .attribute("value")
                .ok_or_else(|| loc.error("<default> needs the attribute `value`"))?;
            self.params
                .entry(name.to_string())
                .or_insert_with(|| value.to_string());
        }
        Ok(())
    }

    fn children(
        &mut self,
        doc: &roxmltree::Document,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        version: (u32, u32),
        depth: usize,
    ) -> Result<Vec<Elem>, SceneError> {
        let mut out = Vec::new();
        for child in node.children().filter(|n| n.is_element()) {
            let loc = location(doc, child, file);
            if depth >= MAX_DEPTH {
                return Err(loc.error(format!("elements nest deeper than {MAX_DEPTH} levels")));
            }
            match child.tag_name().name() {
                "default" => {}
                "include" => out.extend(self.include(child, &loc)?),
                "path" if depth == 0 => {
                    let value = self.substitute(path_value(child, &loc)?, &loc)?;
                    self.resolver.add(&loc, &value)?;
                }
                "path" => return Err(loc.error("<path> must be a child of <scene>")),
                _ => out.push(self.element(doc, child, file, version, loc, depth)?),
            }
        }
        if version < (2, 0) {
            upgrade::plugin(node.attribute("type"), &mut out);
        }
        Ok(out)
    }

    fn element(
        &mut self,
        doc: &roxmltree::Document,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        version: (u32, u32),
        loc: Loc,
        depth: usize,
    ) -> Result<Elem, SceneError> {
        let mut attrs = Vec::new();
        for a in node.attributes() {
            let value = self.substitute(a.value(), &loc)?;
            let value = match (a.name(), version < (2, 0)) {
                ("name", true) => upgrade::snake_case(&value),
                _ => value,
            };
            attrs.push((a.name().to_string(), value));
        }
        let mut tag = node.tag_name().name().to_string();
        if version < (2, 0) {
            tag = upgrade::tag(&tag);
        }
        Ok(Elem {
            tag,
            attrs,
            children: self.children(doc, node, file, version, depth + 1)?,
            loc,
        })
    }

    /// Replaces `$name` by the parameter's value; an unknown one is an error.
    fn substitute(&self, value: &str, loc: &Loc) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::new();
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            let v = self.params.get(name).ok_or_else(|| {
                loc.error(format!(
                    "no value for the parameter ${name} (give one with -D {name}=VALUE or a <default name=\"{name}\" value=\"...\"/>)"
                ))
            })?;
            out.push_str(v);
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }

    /// `<include filename="...">`: the `<scene>` children of another file,
    /// read with its own version.
    fn include(&mut self, node: roxmltree::Node, loc: &Loc) -> Result<Vec<Elem>, SceneError> {
        let name = node
            .attribute("filename")
            .ok_or_else(|| loc.error("<include> needs the attribute `filename`"))?;
        let name = self.substitute(name, loc)?;
        let path = self.resolver.resolve(loc, &name);
        if self.stack.iter().any(|p| p == &path) || self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(loc.error(format!(
                "<include> of {}: the includes form a cycle (or nest deeper than {MAX_INCLUDE_DEPTH})",
                echo(&name)
            )));
        }
        let data = read_regular_file(&path).map_err(|e| {
            loc.error(format!(
                "<include>: cannot read {} (looked in {}): {e}",
                echo(&name),
                self.resolver.places(loc)
            ))
        })?;
        let text = std::str::from_utf8(&data).map_err(|e| SceneError {
            file: path.clone(),
            location: Some(line_column(&data, e.valid_up_to())),
            message: "the file is not UTF-8 text".into(),
        })?;
        Ok(self.scene(text, &path)?.children)
    }
}

/// `<path value="...">`'s folder, as written.
fn path_value<'a>(node: roxmltree::Node<'a, '_>, loc: &Loc) -> Result<&'a str, SceneError> {
    node.attribute("value")
        .ok_or_else(|| loc.error("<path> needs the attribute `value`"))
}

fn location(doc: &roxmltree::Document, node: roxmltree::Node, file: &Rc<PathBuf>) -> Loc {
    let p = doc.text_pos_at(node.range().start);
    Loc {
        file: file.clone(),
        line: p.row as usize,
        column: p.col as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str, defines: &[(&str, &str)]) -> Result<Elem, SceneError> {
        let defines: Vec<(String, String)> = defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Reader::new(&defines, Path::new("t.xml")).scene(text, Path::new("t.xml"))
    }

    #[test]
    fn parameters_come_from_defines_then_defaults() {
        let text = r#"<scene version="3.0.0"><default name="spp" value="4"/>
            <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler></scene>"#;
        let value = |e: &Elem| e.children[0].children[0].attr("value").unwrap().to_string();
        assert_eq!(value(&read(text, &[]).unwrap()), "4");
        assert_eq!(value(&read(text, &[("spp", "9")]).unwrap()), "9");
        let err = read(
            r#"<scene version="3.0.0"><float name="x" value="$nope"/></scene>"#,
            &[],
        )
        .unwrap_err();
        assert_eq!(err.location, Some((1, 24)));
        assert!(err.message.contains("$nope"), "{}", err.message);
    }

    #[test]
    fn deep_nesting_is_refused_not_overflowed() {
        let text = format!(
            "<scene version=\"3.0.0\">{}{}</scene>",
            "<a>".repeat(100_000),
            "</a>".repeat(100_000)
        );
        let err = read(&text, &[]).unwrap_err();
        assert!(err.message.contains("nest deeper"), "{}", err.message);
    }

    #[test]
    fn malformed_xml_is_located() {
        let err = read(
            "<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n</scene>",
            &[],
        )
        .unwrap_err();
        assert_eq!(err.location.map(|l| l.0), Some(3));
        assert!(err.message.starts_with("malformed XML"), "{}", err.message);
    }

    #[test]
    fn old_files_are_upgraded_and_new_ones_are_not() {
        let text = |v: &str| {
            format!(
                r#"<scene version="{v}"><integrator type="path"><integer name="maxDepth" value="3"/></integrator></scene>"#
            )
        };
        let name = |e: Elem| e.children[0].children[0].attr("name").unwrap().to_string();
        assert_eq!(name(read(&text("0.5.0"), &[]).unwrap()), "max_depth");
        assert_eq!(name(read(&text("3.0.0"), &[]).unwrap()), "maxDepth");
    }
}
