"""mrtrace's Python tools: they draw and lay out what the C++ tools measured and computed.

Run a module with scripts/ on the Python path, as scripts/reproduce and scripts/bench do:

    PYTHONPATH=scripts python3 -m mrtrace.plot DIR

  results       reads and checks mrt-compare's DIR/results.json; number formats
  plot          the error-against-run-time plot of one comparison
  page          the markdown page of one comparison (docs/results/SCENE.md)
  headline      the headline ratios as markdown tables
  crops         enlarged crops of a comparison's images, side by side
  index         the index of the results pages (docs/results.md)
  table1        Table 1: preprocessing time and memory of every scene
  bench_report, bench_instances   scripts/bench's summary and instance-count measurement

Every figure the pages print (headline ratios, equal-time RMSEs, times to reach an RMSE,
speed-ups at equal error) is mrt-compare's, from results.json; none is computed here.
"""
