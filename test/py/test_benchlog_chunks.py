

def test_the_replays_estimates_read_in_chunks_are_the_file_with_its_words_as_categories(tmp_path, monkeypatch):
    """metrics.read_estimates reads ESTIMATES_CHUNK_ROWS rows at a time: the same values as the
    whole file read at once, status and part as categories (one copy of each word: 2 000 000 rows
    of them as text took 240 MB in hpddo evaluate)."""
    from hpddo.evaluation import metrics
    n = 1000
    rng = np.random.default_rng(1)
    whole = pd.DataFrame({"t_s": np.arange(n) * 0.5, "rpm_ref": rng.normal(100, 5, n), "rpm_m3": rng.normal(100, 5, n),
                          "status": rng.choice(["ok", "gated", "fallback"], n),
                          "part": np.where(np.arange(n) < 800, "train", "test")})
    whole.loc[990:, "status"] = "clamped"  # a word only the last chunk has
    whole.to_csv(tmp_path / "e.estimates.csv", index=False)
    monkeypatch.setattr(metrics, "ESTIMATES_CHUNK_ROWS", 300)
    got = metrics.read_estimates(tmp_path / "e.estimates.csv")
    assert list(got.columns) == list(whole.columns) and len(got) == n
    assert isinstance(got["status"].dtype, pd.CategoricalDtype) and isinstance(got["part"].dtype, pd.CategoricalDtype)
    pd.testing.assert_frame_equal(got.astype({"status": str, "part": str}), whole.astype({"status": str, "part": str}),
                                  check_exact=False, rtol=1e-15)
    assert (got["status"] == "clamped").sum() == 10 and got.index[got["part"] == "test"][0] == 800
