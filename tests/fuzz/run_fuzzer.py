#!/usr/bin/env python3
"""Runs one libFuzzer target for a bounded time from a copy of its seed corpus
(the source tree is never written). Exit status is the fuzzer's: non-zero when
it found a crash, which is then printed (hex) so the failure is reproducible
from the test log alone."""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('fuzzer')
    ap.add_argument('seeds', nargs='+', help='directories whose files seed the corpus')
    ap.add_argument('--seconds', type=int, default=5)
    ap.add_argument('--rss-limit-mb', type=int, default=4096, help='libFuzzer -rss_limit_mb (and -malloc_limit_mb)')
    ap.add_argument('--libfuzzer', action='append', default=[], help='another libFuzzer flag (-name=value)')
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix='sculpt-fuzz-') as tmp:
        corpus = os.path.join(tmp, 'corpus')
        artifacts = os.path.join(tmp, 'artifacts') + os.sep
        os.makedirs(corpus)
        os.makedirs(artifacts)
        n = 0
        for d in args.seeds:
            for name in sorted(os.listdir(d)):
                src = os.path.join(d, name)
                if os.path.isfile(src):
                    shutil.copyfile(src, os.path.join(corpus, f'{n:04d}-{name}'))
                    n += 1
        # -error_exitcode=1: libFuzzer's own default, 77, is what meson reads as "skipped".
        cmd = [args.fuzzer, f'-max_total_time={args.seconds}', '-timeout=20', f'-rss_limit_mb={args.rss_limit_mb}', '-error_exitcode=1',
               '-max_len=65536', f'-artifact_prefix={artifacts}', '-print_final_stats=1'] + args.libfuzzer + [corpus]
        print('seed files:', n)
        print('running:', ' '.join(cmd), flush=True)
        status = subprocess.call(cmd)
        for name in sorted(os.listdir(artifacts)):
            with open(os.path.join(artifacts, name), 'rb') as f:
                data = f.read()
            print(f'artifact {name} ({len(data)} bytes): {data[:4096].hex()}')
        return status


if __name__ == '__main__':
    sys.exit(main())
