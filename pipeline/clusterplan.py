"""An adaptive plan's candidate plates evaluated on Dask distributed workers (``--scheduler``).

A batch is planned before any of its parts runs. With ``--jobs`` the plans' candidates run
on forked worker processes (:class:`pipeline.runner.PlateEvaluator`); on a cluster they run
on the cluster's workers, which a whole hull's plan otherwise leaves idle while this process
(the coordinator) evaluates hundreds of plates in turn.

The protocol is the forked workers' one: the objects every plate of a surface shares (the
hull surface, its distance structure, its trim; a lofted KVLCC2 shell is 0.6 MB) and the run's
configuration go to the cluster once each, as tasks that return them (a worker that needs
them fetches them once and keeps them while the plan runs); each plate goes as a pickle in
which they are references, and its result comes back the same way, without its part. So a
plate costs its own bytes (about 150 KB back for a hull plate, not the 1 MB its surface
would add), and the evaluations, the cache (a plate evaluated once, whatever configuration
of the batch asks) and the plans are those of ``--jobs``: the files are the same bytes.

The planner's other work for the workers (choosing the splits of the plates that do not
fit, measuring a fit-up's shared edges: :meth:`ClusterEvaluator.map_each`) goes the same way;
a fit-up's developments of formed plates are done in the coordinator. A worker lost while it
works: Dask runs the task again elsewhere; should it give up (``KilledWorker``), the work is
done here.
"""

from __future__ import annotations

import time

from .runner import PlateEvaluator, _dumps, _loads


def _given(value):
    return value


def call_on_worker(func, blob: bytes, shared: list, *args) -> tuple[bytes, float]:
    """On a worker: ``func(item, *args)`` of the item in ``blob`` (its shared objects numbered
    into ``shared``); (the answer as a blob of the same kind, CPU seconds)."""
    cpu = time.process_time()
    answer = func(_loads(blob, shared), *args)
    return _dumps(answer, {id(obj): k for k, obj in enumerate(shared)}), time.process_time() - cpu


def _evaluated(part, evaluate, config):
    """A plate's result without its part (the coordinator attaches its own)."""
    result = evaluate(part, config)
    result.part = None
    return result


class ClusterEvaluator(PlateEvaluator):
    """:class:`pipeline.runner.PlateEvaluator` whose batches of plates run on the workers
    of ``client`` (a ``distributed.Client``); ``evaluate(part, config)``: a module-level
    function (the workers import it). The figures count as the forked evaluator's do
    (``cpu_seconds``: the workers' CPU in the evaluations)."""

    def __init__(self, client, evaluate=None):
        if evaluate is None:
            from .hull.plates import evaluate_plate as evaluate
        super().__init__(evaluate, jobs=1)
        self.client = client
        self._sent: dict = {}  # id(obj) -> (obj, future of it on the cluster)

    def _on_cluster(self, obj):
        """The future of ``obj`` on the cluster, sent once (the object is kept here with
        it, so that its id names it while the plan runs)."""
        if id(obj) not in self._sent:
            self._sent[id(obj)] = (obj, self.client.submit(_given, obj, pure=False))
        return self._sent[id(obj)][1]

    def _compute(self, parts: list, config) -> list:
        if not parts:
            return []
        shared = list({id(obj): obj for part in parts
                       for obj in (part.hull.surface, part.hull.distance, part.hull.trim) if obj is not None}.values())
        index = {id(obj): k for k, obj in enumerate(shared)}
        given = [self._on_cluster(obj) for obj in shared]
        settings = self._on_cluster(config)
        futures = [self.client.submit(call_on_worker, _evaluated, _dumps(part, index), given, self.evaluate, settings,
                                      pure=False) for part in parts]
        results = []
        for part, (result, cpu, here) in zip(parts, self._collect(futures, parts, shared,
                                                                  lambda part: self.evaluate(part, config))):
            self.cpu_seconds += cpu
            self.local_cpu_seconds += cpu if here else 0.0
            result.part = part
            results.append(result)
        return results

    @property
    def running(self) -> bool:
        """The cluster's workers are there for :meth:`map_each` whenever it is asked."""
        return True

    def map_each(self, func, items: list):
        """``func(item)`` of each item on the workers, handed out at once; an iterator of the
        answers in order (``func``: a module-level function). The objects sent for the
        plates so far travel as references; the workers' CPU goes into
        ``mapped_cpu_seconds``."""
        if len(items) < 2:
            return (func(item) for item in items)
        shared = [obj for obj, _ in self._sent.values()]
        given = [future for _, future in self._sent.values()]
        index = {id(obj): k for k, obj in enumerate(shared)}
        futures = [self.client.submit(call_on_worker, func, _dumps(item, index), given, pure=False) for item in items]
        return self._mapped(self._collect(futures, items, shared, func))

    def _mapped(self, answers):
        for answer, cpu, here in answers:
            self.mapped_cpu_seconds += 0.0 if here else cpu
            yield answer

    def _collect(self, futures: list, items: list, shared: list, here):
        """(answer, CPU seconds, computed here) of each future in order: ``here(item)`` in this
        process when Dask gave up on the task (``KilledWorker``); what is not yet read when
        the reader stops is cancelled."""
        from distributed.scheduler import KilledWorker

        try:
            for item, future in zip(items, futures):
                try:
                    blob, cpu = future.result()
                    yield _loads(blob, shared), cpu, False
                except KilledWorker:
                    cpu = time.process_time()
                    answer = here(item)
                    yield answer, time.process_time() - cpu, True
        finally:
            self.client.cancel([f for f in futures if not f.done()])

    def map(self, func, items: list) -> list:
        return list(self.map_each(func, items))

    def close(self) -> None:
        """Let the cluster forget what the plan sent it (the cache stays)."""
        futures = [future for _, future in self._sent.values()]
        self._sent.clear()
        if futures:
            self.client.cancel(futures)
