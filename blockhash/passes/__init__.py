"""The render in passes (stochastic progressive photon mapping), as small parts:

- :mod:`.schedule`: how the passes' radii shrink (Knaus and Zwicker) and the footprint;
- :mod:`.task`: a pass as a task, :func:`~.task.run_pass` (setup, settings, pass number) ->
  its contribution to the film;
- :mod:`.film`: the per-pixel means and their spread, merged in pass order;
- :mod:`.renderer`: one render's state, :class:`~.renderer.Renderer` (the film, the totals,
  passes merged in order, a pass at a time with ``step``);
- :mod:`.plan`: when a render stops and where its passes run, :class:`~.plan.RenderPlan`;
- :mod:`.executors`: in this process, local worker processes; :mod:`.dask_cluster`: an
  existing Dask cluster; :mod:`.worker`: what a worker process keeps;
- :mod:`.run`: the loop, :func:`~.run.run_passes`;
- :mod:`.pipeline`: ``blockhash.render`` and the one-pass ``render_scene``.
"""
