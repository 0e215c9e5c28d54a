#!/usr/bin/env python3
"""Every name the documentation cites exists in the code (CI runs this beside check-layout.py).

Reads README.md, ARCHITECTURE.md, docs/*.md, claims/README.md and scripts/README.md (or the
files given) and checks each code span (`...`, also across a line break), each line of their
fenced `sh`, `toml` and `rust` blocks, and each relative link:

- a file path (`crates/bvh/shaders/bvh.wgsl`, `configs/ci.toml`, `shaders/kd.wgsl`; NAME,
  PAPER, <scene> and * are placeholders) must exist, from the repository's root or as the
  end of a file's path; `results/` (run outputs) and `../` (outside the repository) are not
  checked;
- a Rust path (`experiment::config::load`, `tb_core::GpuProgram::needs_f64`,
  `tb_core::for_each_counter!`) must resolve: each segment a crate (tb_core, ...), a module
  (a file or folder of that name under the crate so far) or a type (its definition and impl
  files), and the last one a word of the files it leads to;
- a command (`trace-bench run ...`, `cargo run --release -- reproduce ...`, `cargo test -p
  tb-kdtree --features ...`, `scripts/shard-local.sh ...`) must name a subcommand of the CLI and
  only flags its clap definition (crates/cli/src/lib.rs) declares, a package, test file and
  feature that exist, and a script's flags that the script mentions; a flag alone must be one
  of the CLI's, the scripts' or cargo's;
- a config key (`run.threads`, `gpu_required = false`, the keys of the `toml` blocks) and any
  other identifier (`NoStats`, `build_stats`, `SHADER_F64`) must be a word of the code
  (crates/, scripts/, configs/, claims/, .ci/);
- a GPU program, traversal, scene or other hyphenated name (`bvh/ordered-w8`,
  `rtree/stackless-mM`, `recursive-direction-sorted`) must appear in the code or in the
  registry's reference generated into docs/structures.md (which the cli test checks);
- a link `[text](path#anchor)` must name a file that exists and a heading of it.

It also checks the shape: README's two set-up commands within its first 40 lines and
ARCHITECTURE.md at most 200 lines. Exit 1 with one line per unknown name, `FILE:LINE: ...`.
Words that are no code names (file formats, units, prose in code font) are in ALLOW.
`scripts/test_scripts.py` tests it (`CheckDocs`): a stale name fails.
"""

import glob
import os
import re
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
DOCS = ["README.md", "ARCHITECTURE.md", "docs/*.md", "claims/README.md", "scripts/README.md"]
CODE_DIRS = ["crates", "scripts", "configs", "claims", ".ci"]
CODE_EXT = (".rs", ".wgsl", ".toml", ".py", ".sh", ".sbatch", ".txt")
CODE_FILES = ["Cargo.toml", ".ci/run", ".gitignore"]
# Not code to cite: this checker and its tests name stale names on purpose.
NOT_CODE = {"scripts/check-docs.py", "scripts/test_scripts.py"}
SETUP = ["cargo run --release -- run configs/quick.toml", "cargo test --workspace --release"]
SETUP_LINES = 40
ARCHITECTURE_LINES = 200
# Top-level folders and files whose paths must exist (anything else path-like may also be a
# name in the code, e.g. a scene `stress/flat` or a program `kdtree/restart`).
STRICT_HEADS = ("crates/", "configs/", "scripts/", "claims/", "docs/", ".ci/", "scenes/")
STRICT_EXT = (".rs", ".wgsl", ".py", ".sh", ".md", ".sbatch")
# Run outputs (a results folder's files), places outside the repository.
UNCHECKED_HEADS = ("results/", "images/", "../", "/", "~", "http")
# Crates of others and primitive types: a path beginning with one is not looked up.
EXTERNAL = {
    "std", "core", "alloc", "f32", "f64", "u32", "u64", "usize", "bytemuck", "glam", "wgpu",
    "rayon", "clap", "serde",
}
# cargo's own flags and libtest's (after `--`).
CARGO_FLAGS = {
    "--release", "--workspace", "--features", "--all-targets", "--all", "--quiet", "--test",
    "--lib", "--bins", "--bin", "--no-run", "--package", "--check", "--nocapture",
    "--ignored", "--include-ignored", "--test-threads", "--exact", "--list", "--locked",
}
# Words in code font that are no code names (a file format, a C library's symbol in a profile):
# kept short, each a reason not to look it up.
ALLOW = {"OBJ.gz", "floorf"}
# The sketch of a new structure in ARCHITECTURE.md stands for names no crate has yet.
FICTIONAL = {"MyParams", "MyTraversal", "MyStructure", "my-structure"}


def read(path):
    with open(path, encoding="utf-8") as fh:
        return fh.read()


class Code:
    """What the documentation may cite: the repository's files, the code's words and Rust
    items, the CLI's subcommands and flags, the crates, features and test files."""

    def __init__(self, root=ROOT):
        self.root = root
        self.texts = {}
        for d in CODE_DIRS:
            for dp, dirs, files in os.walk(os.path.join(root, d)):
                dirs[:] = [x for x in dirs if x not in ("target", "__pycache__", ".venv")]
                for f in files:
                    p = os.path.join(dp, f)
                    rel = os.path.relpath(p, root).replace(os.sep, "/")
                    if (f.endswith(CODE_EXT) or f == "run") and rel not in NOT_CODE:
                        self.texts[rel] = read(p)
        for f in CODE_FILES:
            if os.path.exists(os.path.join(root, f)):
                self.texts[f] = read(os.path.join(root, f))
        self.all = "\n".join(self.texts.values())
        self.words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", self.all))
        self.files = set()
        for dp, dirs, files in os.walk(root):
            dirs[:] = [x for x in dirs if x not in ("target", ".git", "results", "__pycache__")]
            for f in files:
                self.files.add(os.path.relpath(os.path.join(dp, f), root).replace(os.sep, "/"))
        self.dirs = {os.path.dirname(f) for f in self.files}
        self.dirs |= {d for f in list(self.dirs) for d in self._parents(f)}
        self.crates = {}  # tb_core -> crates/core/src
        self.packages = set()
        self.features = set()
        for toml in glob.glob(os.path.join(root, "crates", "*", "Cargo.toml")):
            text = read(toml)
            name = re.search(r'^name\s*=\s*"([^"]+)"', text, re.M).group(1)
            self.packages.add(name)
            src = os.path.relpath(os.path.join(os.path.dirname(toml), "src"), root)
            self.crates[name.replace("-", "_")] = src.replace(os.sep, "/")
            feats = re.search(r"^\[features\]\n(.*?)(?=^\[|\Z)", text, re.M | re.S)
            if feats:
                self.features |= set(re.findall(r"^([\w-]+)\s*=", feats.group(1), re.M))
        self.commands = self._commands()
        self.generated = ""
        ref = os.path.join(root, "docs", "structures.md")
        if os.path.exists(ref):
            self.generated = read(ref)

    @staticmethod
    def _parents(d):
        while d:
            yield d
            d = os.path.dirname(d)

    def _commands(self):
        """Subcommand -> its long and short flags, from the clap derive of the CLI."""
        text = self.texts.get("crates/cli/src/lib.rs", "")
        flags_of = {}

        def flags(body):
            out = set()
            for m in re.finditer(r"#\[arg\((.*?)\)\]\s*\n\s*(?:///[^\n]*\s*)*(\w+)\s*:", body, re.S):
                args, field = m.group(1), m.group(2)
                long = re.search(r'long\s*=\s*"([^"]+)"', args)
                if re.search(r"\blong\b", args):
                    out.add("--" + (long.group(1) if long else field.replace("_", "-")))
                if re.search(r"\bshort\b", args):
                    out.add("-" + field[0])
            for m in re.finditer(r"#\[command\(flatten\)\]\s*\w+\s*:\s*(\w+)", body):
                s = re.search(r"struct " + m.group(1) + r"\s*\{(.*?)\n\}", text, re.S)
                if s:
                    out |= flags(s.group(1))
            return out

        enum = re.search(r"enum Cmd \{(.*?)\n\}", text, re.S)
        if enum:
            parts = re.split(r"\n    (?:///[^\n]*\n    )*([A-Z]\w*)\s*(?=[{,(])", enum.group(1))
            for name, body in zip(parts[1::2], parts[2::2]):
                # `Run(Box<RunArgs>)`: the flags of that argument struct.
                tup = re.match(r"\(\s*(?:Box<)?(\w+)", body)
                if tup:
                    st = re.search(r"struct " + tup.group(1) + r"\s*\{(.*?)\n\}", text, re.S)
                    body = st.group(1) if st else ""
                flags_of[name.lower()] = flags(body) | {"--help", "-h"}
        return flags_of

    def script_flags(self):
        out = set()
        for p, t in self.texts.items():
            if p.startswith("scripts/") or p.startswith(".ci/"):
                out |= set(re.findall(r"(?<![\w-])(--[a-z][\w-]*)", t))
        return out

    def any_flag(self):
        cli = set().union(*self.commands.values()) if self.commands else set()
        return cli | self.script_flags() | CARGO_FLAGS

    def word(self, w):
        return w in self.words

    def in_text(self, s):
        """`s` appears in the code or the generated reference (placeholders: a capital or
        two ending a part, `-mM`, `-N`, `shard-K`, or <...>)."""
        if s in self.all or s in self.generated:
            return True
        parts = re.split(r"((?<=[a-z-])[A-Z]{1,2}\b|<[^>]*>)", s)
        if len(parts) == 1:
            return False
        pat = "".join(r"[\w${}]+" if i % 2 else re.escape(p) for i, p in enumerate(parts))
        return bool(re.search(pat, self.all) or re.search(pat, self.generated))

    # Paths ------------------------------------------------------------------------------

    def path_exists(self, p):
        p = p.rstrip("/").rstrip(".,;:")
        if not p:
            return True
        pat = placeholder_glob(p)
        if any(ch in pat for ch in "*?["):
            hits = glob.glob(os.path.join(self.root, pat))
            return bool(hits)
        return p in self.files or p in self.dirs

    def path_suffix(self, p):
        p = p.rstrip("/")
        pat = placeholder_glob(p)
        rx = re.compile(r"(^|/)" + glob_regex(pat) + r"(/|$)")
        return any(rx.search(f) for f in self.files) or any(rx.search(d) for d in self.dirs)

    # Rust paths -------------------------------------------------------------------------

    def rs_files(self, under=""):
        return [p for p in self.texts if p.endswith(".rs") and p.startswith(under)]

    def resolve(self, path):
        """None when `a::b::c` resolves, else why not."""
        segs = [s for s in path.rstrip("!").split("::") if s]
        if not segs:
            return None
        files = None
        for i, s in enumerate(segs[:-1]):
            if i == 0 and s in ("crate", "self", "super"):
                continue
            if s in self.crates:
                files = self.rs_files(self.crates[s] + "/")
                continue
            pool = files if files is not None else self.rs_files()
            sub = [f for f in pool if re.search(r"(^|/)" + re.escape(s) + r"(\.rs$|/)", f)]
            if sub:
                files = sub
                continue
            tdef = re.compile(
                r"\b(struct|enum|trait|type|union|impl(<[^>]*>)?(\s+[\w:<>]+\s+for)?)\s+"
                + re.escape(s)
                + r"\b"
            )
            macro = re.compile(r"macro_rules!\s*" + re.escape(s) + r"\b")
            pool = pool if any(tdef.search(self.texts[f]) for f in pool) else self.rs_files()
            sub = [f for f in pool if tdef.search(self.texts[f]) or macro.search(self.texts[f])]
            if not sub:
                return f"`{s}` is no crate, module or type"
            files = sub
        last = segs[-1]
        owner = segs[-2] if len(segs) > 1 else None
        if owner and owner[0].isupper() and owner not in self.crates:
            # `Type::member`: defined in the type's own struct, enum, trait or impl bodies, or
            # by a trait or macro (`params!`, `choice!`) every such type gets
            if last in self.members(owner) or last in self.generic_members():
                return None
            return f"`{last}` is no member of `{owner}`"
        pool = files if files is not None else self.rs_files()
        rx = re.compile(r"\b" + re.escape(last) + r"\b")
        if not any(rx.search(self.texts[f]) for f in pool):
            where = "the code" if files is None else "::".join(segs[:-1])
            return f"`{last}` is not in {where}"
        return None

    def members(self, ty):
        """Names defined in the bodies of `struct|enum|trait|union ty` and `impl … ty`:
        functions, constants, types, fields and variants."""
        head = re.compile(
            r"\b(?:(?:struct|enum|trait|union)\s+" + re.escape(ty) + r"\b"
            r"|impl\b(?:<[^{;]*?>)?\s+(?:[\w:<>, ']+\s+for\s+)?(?:[\w:]+::)?"
            + re.escape(ty)
            + r"\b)[^{;]*\{"
        )
        out = set()
        for f in self.rs_files():
            text = self.texts[f]
            for m in head.finditer(text):
                out |= defined_in(body_at(text, m.end() - 1))
        return out

    def generic_members(self):
        """Names defined in trait bodies and macro_rules! bodies anywhere (what a derive, a
        blanket trait or a declaring macro gives a type)."""
        if not hasattr(self, "_generic"):
            self._generic = set()
            head = re.compile(r"\b(?:trait\s+\w+[^{;]*|macro_rules!\s*\w+\s*)\{")
            for f in self.rs_files():
                text = self.texts[f]
                for m in head.finditer(text):
                    self._generic |= defined_in(body_at(text, m.end() - 1))
        return self._generic


def body_at(text, i):
    """The text between the brace at `i` and its match (braces counted, strings not parsed)."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return text[i + 1 : j]
    return text[i + 1 :]


def defined_in(body):
    """Names a Rust body defines: fn, const, static, type, fields and enum variants."""
    out = set(re.findall(r"\bfn\s+(\w+)", body))
    out |= set(re.findall(r"\b(?:const|static|type)\s+(?!fn\b)(\w+)", body))
    out |= set(re.findall(r"^\s*(?:pub(?:\([\w:]+\))?\s+)?(\w+)\s*:(?!:)", body, re.M))
    out |= set(re.findall(r"^\s*([A-Z]\w*)\s*(?:[,({=]|$)", body, re.M))
    return out


def placeholder_glob(p):
    """A path with its placeholders (NAME, PAPER, <scene>, {a,b}, …) as `*`."""
    p = re.sub(r"<[^>]*>", "*", p)
    p = re.sub(r"\{[^}]*\}", "*", p)
    p = re.sub(r"\[[^\]]*\]", "*", p)
    p = p.replace("…", "*")
    p = re.sub(r"\b[A-Z][A-Z_]+\b", "*", p)
    return p


def glob_regex(pat):
    return "".join("[^/]*" if c == "*" else "[^/]" if c == "?" else re.escape(c) for c in pat)


# What a code span is ----------------------------------------------------------------------

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
RUST_PATH = re.compile(rf"(?<![\w/.-])((?:{IDENT}::)+{IDENT}!?)")
FILE_EXT = re.compile(r"\.(rs|wgsl|toml|md|py|sh|sbatch|csv|json|txt|lock|exr|png|obj|gz)$")


def check_command(cmd, code, errs):
    """The flags, subcommand, package, feature and test file of one command line."""
    cmd = re.sub(r"^\s*(\w+=\S+\s+)+", "", cmd)  # leading VAR=value assignments
    words = cmd.split()
    if not words:
        return
    head = words[0]
    if head in ("cargo",):
        if len(words) > 1 and words[1] == "run":
            if "--" in words:
                k = words.index("--")
                check_cargo(words[1:k], code, errs)
                check_cli(words[k + 1 :], code, errs)
            else:
                check_cargo(words[1:], code, errs)
        else:
            k = words.index("--") if "--" in words else len(words)
            check_cargo(words[1:k], code, errs)
            for w in words[k + 1 :]:
                if w.startswith("--") and w.split("=")[0] not in CARGO_FLAGS:
                    errs.append(f"libtest flag `{w}` unknown")
    elif head == "trace-bench":
        check_cli(words[1:], code, errs)
    elif head in ("python3", "python") and len(words) > 1 and not words[1].startswith("-"):
        check_script(words[1], words[2:], code, errs)
    elif head.startswith("scripts/") or head.startswith(".ci/"):
        check_script(head, words[1:], code, errs)


def check_cargo(args, code, errs):
    for i in range(len(args)):
        w = args[i]
        val = args[i + 1] if i + 1 < len(args) else ""
        if w in ("-p", "--package"):
            if val not in code.packages:
                errs.append(f"package `{val}` unknown")
        elif w == "--features":
            for f in re.split(r"[, ]", val):
                if f and f not in code.features:
                    errs.append(f"feature `{f}` unknown")
        elif w == "--test":
            tests = (f"/tests/{val}.rs", f"/tests/{val}/main.rs")
            if not any(p.endswith(tests) for p in code.files):
                errs.append(f"test `{val}` unknown (no tests/{val}.rs)")
        elif w.startswith("--") and w.split("=")[0] not in CARGO_FLAGS:
            errs.append(f"cargo flag `{w}` unknown")


def check_cli(args, code, errs):
    if not args:
        return
    sub = args[0]
    if sub not in code.commands:
        if not sub.startswith("-") and not re.fullmatch(r"[A-Z]+|\[.*", sub):
            errs.append(f"`trace-bench {sub}`: no such subcommand")
        return
    for w in args[1:]:
        for f in re.findall(r"(?<![\w-])(--?[a-z][\w-]*)", w):
            if f.startswith("--") or re.fullmatch(r"-[a-z]", f):
                if f not in code.commands[sub]:
                    errs.append(f"`trace-bench {sub}` has no flag `{f}`")
    for m in re.finditer(r"--set\s+([\w.]+)=", " ".join(args)):
        check_dotted(m.group(1), code, errs)


def check_script(path, args, code, errs):
    if not code.path_exists(path):
        errs.append(f"script `{path}` does not exist")
        return
    text = code.texts.get(path, "")
    for w in args:
        f = w.split("=")[0]
        if f.startswith("--") and f not in text:
            errs.append(f"`{path}` has no flag `{f}`")


def check_dotted(key, code, errs):
    for seg in key.split("."):
        if seg and not seg.isdigit() and not code.word(seg) and seg not in ALLOW:
            errs.append(f"`{seg}` (of `{key}`) is no word of the code")


def check_span(span, code, errs, rust_block=False):
    """The checks of one code span (or one line of a rust block)."""
    s = span.strip()
    if not s or s in ALLOW or s in FICTIONAL:
        return
    if s.startswith(UNCHECKED_HEADS):
        return
    for p in RUST_PATH.findall(s):
        head = p.split("::")[0]
        if head in FICTIONAL or head in EXTERNAL:
            continue
        if rust_block and head not in code.crates and not code.word(head):
            continue
        why = code.resolve(p)
        if why:
            errs.append(f"`{p}`: {why}")
    if rust_block:
        return
    if re.match(r"^(cargo|trace-bench|python3?|scripts/|\.ci/)\b", s) or re.match(
        r"^(\w+=\S+\s+)+(cargo|scripts/)", s
    ):
        check_command(s, code, errs)
        return
    if "::" in s:
        return
    if re.fullmatch(r"--?[a-z][\w-]*(=\S*)?(\s.*)?", s):
        f = s.split()[0].split("=")[0]
        if f.startswith("--") and f not in code.any_flag():
            errs.append(f"flag `{f}` is the CLI's, no script's or cargo's")
        return
    if s.startswith("builtin:"):
        name = re.split(r"[?&]", s[len("builtin:") :])[0]
        if name and not code.in_text(name):
            errs.append(f"built-in scene `{name}` unknown")
        return
    if " " not in s and ("/" in s or FILE_EXT.search(s)):
        check_path(s, code, errs)
        return
    if re.fullmatch(r"(\[\[?)?[A-Za-z_][\w]*(\.[\w]+)+(\]\]?)?", s):  # run.threads, meta.adapter
        check_dotted(s.strip("[]"), code, errs)
        return
    m = re.fullmatch(r"\[\[?(\w+)\]\]?", s)
    if m:
        check_dotted(m.group(1), code, errs)
        return
    if re.fullmatch(r"_[A-Z][A-Z0-9_]*", s):  # the end of a name, `_MIN`
        if s not in code.all:
            errs.append(f"`{s}` appears nowhere in the code")
        return
    if re.fullmatch(IDENT + r"!?(\(\))?", s):
        w = s.rstrip("()!")
        if w not in ALLOW and w not in FICTIONAL and not code.word(w):
            errs.append(f"`{w}` is no word of the code")
        return
    if re.fullmatch(r"[a-z0-9]+(-[a-z0-9]+)+", s) or re.fullmatch(r"-[a-z][\w-]*", s):
        if not code.in_text(s):
            errs.append(f"`{s}` appears nowhere in the code")
        return
    keys = re.findall(r"(?:^|[,;{]\s*)([A-Za-z_][\w.]*)\s*=(?!=)", s)
    if keys and re.match(r"^[A-Za-z_][\w.]*\s*=", s):
        for k in keys:
            check_dotted(k, code, errs)
        return
    words = s.split()
    if words[0] in code.commands and any(w.startswith("--") for w in words):
        check_cli(words, code, errs)  # `weights --csv`: a subcommand without the binary
        return
    if s.startswith(("pd.", "pandas.", "valgrind", "perf ")):
        return
    # Prose in code font (`trace_ms_ci > run.target_ci`, `impl Structure`): its names with an
    # underscore, its CamelCase names and its dotted keys.
    for w in re.findall(r"(?<![\w.'\"-])([A-Za-z_]\w*(?:\.\w+)*)(?![\w'\"(-])", s):
        if "." in w:
            check_dotted(w, code, errs)
        elif ("_" in w.strip("_") or re.match(r"[A-Z][a-z]+[A-Z]", w)) and w not in ALLOW:
            if not code.word(w) and w not in FICTIONAL:
                errs.append(f"`{w}` (in `{s}`) is no word of the code")


def check_path(p, code, errs):
    p = p.split("#")[0].rstrip(".,;:")
    if p.startswith(UNCHECKED_HEADS) or p in ALLOW:
        return
    if code.path_exists(p):
        return
    if p.startswith(STRICT_HEADS) or re.fullmatch(r"[A-Z][A-Z_]*\.md|Cargo\.(toml|lock)", p):
        errs.append(f"path `{p}` does not exist")
        return
    if p.endswith(STRICT_EXT):  # `shaders/kd.wgsl`, `lib.rs`: some file's path ends so
        if not code.path_suffix(p):
            errs.append(f"no file's path ends with `{p}`")
        return
    if code.path_suffix(p) or code.in_text(p):
        return
    if "/" not in p:  # a file name: a format, an output the code names
        base = re.sub(r"^[^.]*", "", p)
        if code.in_text(p.split(".")[0]) or base in (".csv", ".json", ".exr", ".png", ".toml"):
            return
    errs.append(f"`{p}` is no file and appears nowhere in the code")


# Markdown ---------------------------------------------------------------------------------


def anchors(text):
    out = set()
    for line in text.split("\n"):
        m = re.match(r"^#+\s+(.*)", line)
        if m:
            h = m.group(1).strip().lower()
            h = re.sub(r"[^\w\- ]", "", h)
            out.add(h.replace(" ", "-"))
    return out


def check_doc(path, text, code):
    """Unknown names of one document: a list of `PATH:LINE: why`."""
    found = []  # (line, why)
    fence = None
    para = []  # (line number, text) of the paragraph so far: a span may cross a line break

    def flush():
        if not para:
            return
        start, block = para[0][0], "\n".join(t for _, t in para)
        for m in re.finditer(r"(?<!`)`([^`]+)`(?!`)", block):
            errs = []
            check_span(" ".join(m.group(1).split()), code, errs)
            found.extend((start + block.count("\n", 0, m.start()), e) for e in errs)
        for m in re.finditer(r"\]\(([^)\s]+)\)", block):
            errs = []
            check_link(path, m.group(1), code, errs)
            found.extend((start + block.count("\n", 0, m.start()), e) for e in errs)
        para.clear()

    for n, line in enumerate(text.split("\n"), 1):
        errs = []
        m = re.match(r"^\s*```(\w*)", line)
        if m:
            flush()
            fence = None if fence is not None else m.group(1)
            continue
        if fence is None:
            if line.strip() and not line.startswith("#"):
                para.append((n, line))
            else:
                flush()
                for span in re.findall(r"(?<!`)`([^`]+)`(?!`)", line):
                    check_span(span, code, errs)
        elif fence in ("sh", "bash", "console"):
            cmd = line.split(" #")[0].strip()
            if cmd and not cmd.startswith("#"):
                for part in re.split(r"&&|\|\||;|\$\(|\)", cmd):
                    check_command(part.strip().replace("jid=", ""), code, errs)
        elif fence == "toml":
            m = re.match(r"^\s*(\[\[?[\w.]+\]\]?|[A-Za-z_][\w.]*)\s*(=|$|#)", line)
            if m:
                check_dotted(m.group(1).strip("[]"), code, errs)
        elif fence == "rust":
            check_span(line.split("//")[0], code, errs, rust_block=True)
        elif fence == "":
            check_plain(line, code, errs)
        found.extend((n, e) for e in errs)
    flush()
    out = []
    for n, e in sorted(dict.fromkeys(found)):
        out.append(f"{path}:{n}: {e}")
    return out


def check_plain(line, code, errs):
    """A line of an unlabelled block (a crate map): its file and folder names, its CamelCase
    and snake_case names and its macros."""
    for tok in re.findall(r"[\w./-]+", line):
        tok = tok.rstrip(".,;:")
        if FILE_EXT.search(tok) or (tok.endswith("/") and len(tok) > 2):
            if tok in ALLOW or tok.startswith(UNCHECKED_HEADS):
                continue
            if not code.path_exists(tok) and not code.path_suffix(tok):
                errs.append(f"no file or folder's path ends with `{tok}`")
    for w in re.findall(r"(?<![\w.-])([A-Za-z_]\w*)(!?)(?![\w-])", line):
        name, bang = w
        named = bang or "_" in name.strip("_") or re.match(r"[A-Z][a-z0-9]+[A-Z]", name)
        if named and not code.word(name):
            if name not in ALLOW and name not in FICTIONAL:
                errs.append(f"`{name}{bang}` is no word of the code")


def check_link(doc, target, code, errs):
    if re.match(r"^[a-z]+:", target):
        return
    file, _, anchor = target.partition("#")
    base = os.path.dirname(doc)
    rel = os.path.normpath(os.path.join(base, file)) if file else doc
    rel = rel.replace(os.sep, "/")
    full = os.path.join(code.root, rel)
    if not os.path.exists(full):
        errs.append(f"link to `{target}`: no file `{rel}`")
        return
    if anchor and rel.endswith(".md") and anchor not in anchors(read(full)):
        errs.append(f"link to `{target}`: `{rel}` has no heading `#{anchor}`")


def check_shape(code, texts):
    out = []
    readme = texts.get("README.md")
    if readme is not None:
        first = "\n".join(readme.split("\n")[:SETUP_LINES])
        for c in SETUP:
            if c not in first:
                out.append(
                    f"README.md: the set-up command `{c}` is not within its first "
                    f"{SETUP_LINES} lines"
                )
    arch = texts.get("ARCHITECTURE.md")
    if arch is not None:
        n = len(arch.rstrip("\n").split("\n"))
        if n > ARCHITECTURE_LINES:
            out.append(f"ARCHITECTURE.md: {n} lines, more than {ARCHITECTURE_LINES}")
    return out


def main(argv):
    code = Code()
    paths = argv or [p for d in DOCS for p in sorted(glob.glob(os.path.join(ROOT, d)))]
    texts = {}
    for p in paths:
        rel = os.path.relpath(os.path.abspath(p), ROOT).replace(os.sep, "/")
        texts[rel] = read(os.path.join(ROOT, rel))
    errors = check_shape(code, texts)
    for rel, text in texts.items():
        errors += check_doc(rel, text, code)
    for e in errors:
        print(e)
    if errors:
        print(f"check-docs: {len(errors)} unknown names or shape violations in {len(texts)} "
              "documents")
        return 1
    print(f"check-docs: {len(texts)} documents, every cited name found")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
