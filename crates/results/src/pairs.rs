//! The `k=v;k=v` text of the `params` and `build_stats` columns: one reader for every place
//! that reads them (the summary table, the images' file tags, the claims' selectors,
//! results.json and params.csv), and the writer of `build_stats` (`params` is written by
//! `tb_core::ParamSet`'s `Display`, in the same form; a test here reads it back).

/// The `(key, value)` pairs of `s` in order: parts separated by `;`, empty parts skipped, a
/// part without `=` a key with an empty value; keys and values trimmed.
pub fn pairs(s: &str) -> impl Iterator<Item = (&str, &str)> + '_ {
    s.split(';').filter(|p| !p.trim().is_empty()).map(|p| {
        let (k, v) = p.split_once('=').unwrap_or((p, ""));
        (k.trim(), v.trim())
    })
}

/// `k=v;k=v` of `pairs`, in their order.
pub fn join<K: std::fmt::Display, V: std::fmt::Display>(
    pairs: impl IntoIterator<Item = (K, V)>,
) -> String {
    pairs
        .into_iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_read_what_join_writes() {
        let text = join([("leaf_size", "4"), ("sah", "true"), ("mode", "a=b")]);
        assert_eq!(text, "leaf_size=4;sah=true;mode=a=b");
        let back: Vec<_> = pairs(&text).collect();
        assert_eq!(back, [("leaf_size", "4"), ("sah", "true"), ("mode", "a=b")]);
        assert_eq!(pairs("").count(), 0);
        assert_eq!(pairs("a=1;;b").collect::<Vec<_>>(), [("a", "1"), ("b", "")]);
        assert_eq!(pairs(" a = 1 ").collect::<Vec<_>>(), [("a", "1")]);
    }

    #[test]
    fn pairs_read_a_param_sets_text() {
        use tb_core::ParamValue;
        let set = tb_core::ParamSet(vec![
            ("leaf_size", ParamValue::Int(4)),
            ("sah", ParamValue::Bool(true)),
            ("mode", ParamValue::Str("sbvh".into())),
        ]);
        let text = set.to_string();
        assert_eq!(
            pairs(&text).collect::<Vec<_>>(),
            [("leaf_size", "4"), ("sah", "true"), ("mode", "sbvh")]
        );
    }
}
