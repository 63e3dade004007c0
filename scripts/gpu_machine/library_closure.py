#!/usr/bin/env python3
"""Stages the shared libraries that programs need on a machine that lacks them
(the GPU machine: Ubuntu 24.04 without ROS or OpenCV), for
scripts/gpu_machine/stage_ros_gpu.sh and scripts/gpu_machine/stage_map_gpu.sh.

usage: library_closure.py TREE DEVEL_LIB ROOT... [--stub SONAME]... [--returning SYMBOL]...

Copies into TREE/lib every library that the ROOT programs and the libraries
already in TREE/lib need (readelf NEEDED, transitively), found in DEVEL_LIB,
CUDA's and the system's library folders, except glibc and the compiler's
runtime (the target has newer ones). A --stub library is not copied but
replaced by a stub that defines the symbols its users import from it: a
function stops the program (ud2) if it is ever called, an object is zeros.
OpenCV's image codecs import GDAL, GDCM and OpenEXR for formats our programs
never read; GDAL alone would pull in ~120 MB. A --returning symbol's stub
returns instead (OpenCV calls GDALAllRegister when it builds its list of
decoders, i.e. on the first imread)."""
import argparse
import os
import re
import shutil
import subprocess
import sys

# From the target system (glibc and the compiler's runtime, newer there).
SYSTEM = {'libc.so.6', 'libm.so.6', 'libpthread.so.0', 'libdl.so.2', 'librt.so.1', 'libresolv.so.2',
          'ld-linux-x86-64.so.2', 'libstdc++.so.6', 'libgcc_s.so.1'}


def needed(path):
    out = subprocess.run(['readelf', '-dW', path], capture_output=True, text=True, check=True).stdout
    return re.findall(r'\(NEEDED\).*\[(.*)\]', out)


def dynamic_symbols(path, defined):
    """name -> (type, size) of the global dynamic symbols `path` defines
    (defined=True) or imports (False)."""
    out = subprocess.run(['readelf', '--dyn-syms', '-W', path], capture_output=True, text=True, check=True).stdout
    symbols = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) < 8 or not f[0].endswith(':') or f[0] == 'Num:':
            continue
        size, kind, bind, ndx, name = f[2], f[3], f[4], f[6], f[7]
        if '@' in name or bind == 'LOCAL':
            continue
        if defined == (ndx != 'UND'):
            symbols[name] = (kind, int(size, 0) if size.startswith('0x') else int(size))
    return symbols


def stub_source(wanted, real, returning):
    asm = ['.text']
    for s in sorted(wanted):
        kind, _ = real[s]
        if kind in ('FUNC', 'IFUNC', 'NOTYPE'):
            body = 'ret' if s in returning else 'ud2'
            asm += ['.globl "%s"' % s, '.type "%s", @function' % s, '"%s": %s' % (s, body)]
    asm.append('.bss')
    for s in sorted(wanted):
        kind, size = real[s]
        if kind == 'OBJECT':
            asm += ['.globl "%s"' % s, '.type "%s", @object' % s, '.size "%s", %d' % (s, size), '.balign 16',
                    '"%s": .zero %d' % (s, max(size, 1))]
        elif kind not in ('FUNC', 'IFUNC', 'NOTYPE'):
            sys.exit('cannot stub %s %s' % (kind, s))
    return '\n'.join(asm) + '\n'


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('tree')
    parser.add_argument('devel_lib')
    parser.add_argument('roots', nargs='+')
    parser.add_argument('--stub', action='append', default=[])
    parser.add_argument('--returning', action='append', default=[])
    args = parser.parse_args()
    lib = os.path.join(args.tree, 'lib')
    dirs = [args.devel_lib, '/usr/local/cuda/lib64', '/usr/local/cuda/lib', '/lib/x86_64-linux-gnu',
            '/usr/lib/x86_64-linux-gnu', '/lib', '/usr/lib']

    def find(name):
        for d in dirs:
            p = os.path.join(d, name)
            if os.path.exists(p):
                return p
        sys.exit('library not found: ' + name)

    roots = list(args.roots) + [os.path.join(lib, f) for f in os.listdir(lib)]
    kept, stubbed_by = {}, {}  # soname -> source path; stub -> libraries needing it
    todo = list(roots)
    while todo:
        path = todo.pop()
        for n in needed(path):
            if n in SYSTEM or n in kept:
                continue
            if n in args.stub:
                stubbed_by.setdefault(n, set()).add(path)
                continue
            if os.path.exists(os.path.join(lib, n)):  # staged already (the package's own)
                continue
            kept[n] = find(n)
            todo.append(kept[n])
    for n, src in kept.items():
        shutil.copyfile(os.path.realpath(src), os.path.join(lib, n))

    defined_elsewhere = set()
    for p in [os.path.join(lib, f) for f in os.listdir(lib)] + roots:
        defined_elsewhere.update(dynamic_symbols(p, True))
    for stub, users in sorted(stubbed_by.items()):
        real = dynamic_symbols(find(stub), True)
        wanted = set()
        for u in users:
            wanted.update(s for s in dynamic_symbols(u, False) if s in real and s not in defined_elsewhere)
        src = os.path.join(args.tree, '..', stub + '.s')
        with open(src, 'w') as f:
            f.write(stub_source(wanted, real, set(args.returning)))
        subprocess.run(['gcc', '-shared', '-nostdlib', '-Wl,-soname,' + stub, '-o', os.path.join(lib, stub), src],
                       check=True)
        os.remove(src)
        print('stub %s: %d symbols for %s' % (stub, len(wanted), ', '.join(sorted(os.path.basename(u) for u in users))))
    total = sum(os.path.getsize(os.path.join(lib, f)) for f in os.listdir(lib))
    print('%d libraries, %.1f MB' % (len(os.listdir(lib)), total / 1e6))


if __name__ == '__main__':
    main()
