import sys, time
from bench.bench_fleet import fleet, reader_rates
if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    with fleet(n, 2) as (sup, arms):
        rates = reader_rates([a.ports["develop"] for a in arms], 2.0)
        print("min rate", min(rates), flush=True)
        t0 = time.perf_counter(); print("parent stop at", t0, flush=True)
        import threading, os, signal
        def poke():
            for d in (0.5, 1.0, 1.5):
                time.sleep(50)
                for w in sup.workers:
                    try: os.kill(w.process.pid, signal.SIGUSR1)
                    except Exception: pass
        threading.Thread(target=poke, daemon=True).start()
        sup.stop()
        print("stop took", time.perf_counter() - t0, flush=True)
