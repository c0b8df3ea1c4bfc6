#!/usr/bin/env python3
"""Writes the small meshes and scenes under tests/data (committed; rerun to
regenerate). Everything is derived from one icosphere and a cube so tests can
state exact expected counts."""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def icosphere(subdivisions, radius=1.0):
    t = (1.0 + 5 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]

    def norm(v):
        n = math.sqrt(sum(c * c for c in v))
        return tuple(c / n for c in v)

    verts = [norm(v) for v in verts]
    for _ in range(subdivisions):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                va, vb = verts[a], verts[b]
                verts.append(norm(tuple((x + y) / 2 for x, y in zip(va, vb))))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    # Round through float32 so every writer emits the same values.
    verts = [tuple(struct.unpack('<3f', struct.pack('<3f', *(c * radius for c in v)))) for v in verts]
    return verts, faces


def cube():
    v = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    # index = 4x + 2y + z; two outward triangles per face
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = []
    for a, b, c, d in quads:
        f += [(a, b, c), (a, c, d)]
    return v, f


def fmt(x):
    return repr(float(x))


def normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    w = [c[i] - a[i] for i in range(3)]
    n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
    l = math.sqrt(sum(x * x for x in n)) or 1.0
    return tuple(x / l for x in n)


def write(path, data, mode='w'):
    full = os.path.join(HERE, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, mode) as f:
        f.write(data)


def obj_smooth(v, f, comment):
    out = [f'# {comment}']
    out += [f'v {fmt(a)} {fmt(b)} {fmt(c)}' for a, b, c in v]
    out += [f'f {a + 1} {b + 1} {c + 1}' for a, b, c in f]
    return '\n'.join(out) + '\n'


def obj_faceted(v, f):
    # Every triangle has its own three vertices and one face normal: what a
    # "flat shaded" export looks like. assimp keeps them apart; we weld.
    out = ['# faceted icosphere: 3 vertices and a normal per triangle']
    k = 1
    for a, b, c in f:
        n = normal(v[a], v[b], v[c])
        out += [f'v {fmt(x)} {fmt(y)} {fmt(z)}' for x, y, z in (v[a], v[b], v[c])]
        out.append(f'vn {fmt(n[0])} {fmt(n[1])} {fmt(n[2])}')
        out.append(f'f {k}//{(k + 2) // 3} {k + 1}//{(k + 2) // 3} {k + 2}//{(k + 2) // 3}')
        k += 3
    return '\n'.join(out) + '\n'


def ply_ascii(v, f):
    out = ['ply', 'format ascii 1.0', f'element vertex {len(v)}', 'property float x',
           'property float y', 'property float z', f'element face {len(f)}',
           'property list uchar int vertex_indices', 'end_header']
    out += [f'{fmt(a)} {fmt(b)} {fmt(c)}' for a, b, c in v]
    out += [f'3 {a} {b} {c}' for a, b, c in f]
    return '\n'.join(out) + '\n'


def ply_binary(v, f):
    head = '\n'.join(['ply', 'format binary_little_endian 1.0', f'element vertex {len(v)}',
                      'property float x', 'property float y', 'property float z',
                      f'element face {len(f)}', 'property list uchar int vertex_indices',
                      'end_header']) + '\n'
    body = b''.join(struct.pack('<3f', *p) for p in v)
    body += b''.join(struct.pack('<B3i', 3, *t) for t in f)
    return head.encode() + body


def stl_ascii(v, f):
    out = ['solid icosphere']
    for a, b, c in f:
        n = normal(v[a], v[b], v[c])
        out.append(f'  facet normal {n[0]:e} {n[1]:e} {n[2]:e}')
        out.append('    outer loop')
        for p in (v[a], v[b], v[c]):
            out.append(f'      vertex {fmt(p[0])} {fmt(p[1])} {fmt(p[2])}')
        out.append('    endloop')
        out.append('  endfacet')
    out.append('endsolid icosphere')
    return '\n'.join(out) + '\n'


def stl_binary(v, f):
    head = b'binary icosphere for sculptd tests'.ljust(80, b' ')
    body = struct.pack('<I', len(f))
    for a, b, c in f:
        body += struct.pack('<3f', *normal(v[a], v[b], v[c]))
        body += struct.pack('<9f', *v[a], *v[b], *v[c]) + struct.pack('<H', 0)
    return head + body


def gltf_parts(v, f, node):
    pos = b''.join(struct.pack('<3f', *p) for p in v)
    idx = b''.join(struct.pack('<3I', *t) for t in f)
    lo = [min(p[i] for p in v) for i in range(3)]
    hi = [max(p[i] for p in v) for i in range(3)]
    doc = {
        'asset': {'version': '2.0', 'generator': 'sculptd tests/data/generate.py'},
        'scene': 0, 'scenes': [{'nodes': [0]}], 'nodes': [dict(node, mesh=0)],
        'meshes': [{'primitives': [{'attributes': {'POSITION': 0}, 'indices': 1, 'mode': 4}]}],
        'accessors': [
            {'bufferView': 0, 'componentType': 5126, 'count': len(v), 'type': 'VEC3', 'min': lo, 'max': hi},
            {'bufferView': 1, 'componentType': 5125, 'count': 3 * len(f), 'type': 'SCALAR'}],
        'bufferViews': [{'buffer': 0, 'byteOffset': 0, 'byteLength': len(pos), 'target': 34962},
                        {'buffer': 0, 'byteOffset': len(pos), 'byteLength': len(idx), 'target': 34963}],
        'buffers': [{'byteLength': len(pos) + len(idx)}],
    }
    return doc, pos + idx


def gltf_embedded(v, f, node):
    doc, binary = gltf_parts(v, f, node)
    doc['buffers'][0]['uri'] = 'data:application/octet-stream;base64,' + base64.b64encode(binary).decode()
    return json.dumps(doc, indent=1) + '\n'


def glb(v, f, node):
    doc, binary = gltf_parts(v, f, node)
    js = json.dumps(doc).encode()
    js += b' ' * (-len(js) % 4)
    binary += b'\0' * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return (struct.pack('<III', 0x46546C67, 2, total) + struct.pack('<II', len(js), 0x4E4F534A) + js +
            struct.pack('<II', len(binary), 0x004E4942) + binary)


def off(v, f):
    out = ['OFF', f'{len(v)} {len(f)} 0']
    out += [f'{fmt(a)} {fmt(b)} {fmt(c)}' for a, b, c in v]
    out += [f'3 {a} {b} {c}' for a, b, c in f]
    return '\n'.join(out) + '\n'


def main():
    s2 = icosphere(2, 0.1)   # 162 vertices, 480 edges, 320 triangles
    s1 = icosphere(1, 0.1)   # 42 vertices, 120 edges, 80 triangles
    cv, cf = cube()          # 8 vertices, 18 edges, 12 triangles

    write('meshes/icosphere.obj', obj_smooth(*s2, 'icosphere, radius 0.1, 2 subdivisions'))
    write('meshes/icosphere_faceted.obj', obj_faceted(*s2))
    write('meshes/icosphere_ascii.ply', ply_ascii(*s2))
    write('meshes/icosphere_binary.ply', ply_binary(*s2), 'wb')
    write('meshes/icosphere_ascii.stl', stl_ascii(*s1))
    write('meshes/icosphere_binary.stl', stl_binary(*s2), 'wb')
    write('meshes/icosphere.off', off(*s2))
    write('meshes/icosphere.glb', glb(*s2, {}), 'wb')
    # Unit cube; node: scale 2, then rotate 90° about z, then move to (1, 2, 3):
    # the baked box spans x 0..2, y 1..3, z 2..4.
    node = {'translation': [1.0, 2.0, 3.0], 'rotation': [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)],
            'scale': [2.0, 2.0, 2.0]}
    write('meshes/cube_node_transform.gltf', gltf_embedded(cv, cf, node))
    # The usual layout from Blender: JSON plus a .bin next to it, found relative to the .gltf.
    doc, binary = gltf_parts(cv, cf, {'translation': [0.0, 0.0, -5.0]})
    doc['buffers'][0]['uri'] = 'cube_external.bin'
    write('meshes/cube_external.gltf', json.dumps(doc, indent=1) + '\n')
    write('meshes/cube_external.bin', binary, 'wb')

    # Two cubes as two objects in one file: merged into one body, two components.
    two = ['# two unit cubes, 3 apart on x']
    for k, dx in enumerate((0.0, 3.0)):
        two.append(f'o cube{k}')
        two += [f'v {fmt(x + dx)} {fmt(y)} {fmt(z)}' for x, y, z in cv]
        two += [f'f {a + 1 + 8 * k} {b + 1 + 8 * k} {c + 1 + 8 * k}' for a, b, c in cf]
    write('meshes/two_cubes.obj', '\n'.join(two) + '\n')

    # An open 4x4 grid of quads: 25 vertices, 32 triangles, 16 boundary edges.
    grid = ['# open 4x4 grid in the xz plane']
    grid += [f'v {fmt(i * 0.25)} 0.0 {fmt(j * 0.25)}' for j in range(5) for i in range(5)]
    for j in range(4):
        for i in range(4):
            a = j * 5 + i + 1
            grid.append(f'f {a} {a + 5} {a + 6} {a + 1}')
    write('meshes/open_grid.obj', '\n'.join(grid) + '\n')

    # Bad files: each must give one clear error.
    write('bad/nan.obj', '# a NaN coordinate\nv 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n')
    write('bad/inf.ply', '\n'.join(['ply', 'format ascii 1.0', 'element vertex 3', 'property float x',
                                    'property float y', 'property float z', 'element face 1',
                                    'property list uchar int vertex_indices', 'end_header',
                                    '0 0 0', '1 0 0', '0 inf 0', '3 0 1 2']) + '\n')
    # assimp clamps a bad OFF index (and logs it: a warning for us) but rejects a bad PLY one.
    write('bad/index_out_of_range.off', 'OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n')
    write('bad/index_out_of_range.ply', '\n'.join(['ply', 'format ascii 1.0', 'element vertex 3',
                                                   'property float x', 'property float y', 'property float z',
                                                   'element face 1', 'property list uchar int vertex_indices',
                                                   'end_header', '0 0 0', '1 0 0', '0 1 0', '3 0 1 9']) + '\n')
    write('bad/empty.stl', '')
    write('bad/no_triangles.obj', '# vertices only\nv 0 0 0\nv 1 0 0\nv 0 1 0\n')
    flat = struct.pack('<3f', 0, 0, 0)
    write('bad/all_degenerate.stl', b'degenerate facets'.ljust(80, b' ') + struct.pack('<I', 2) +
          (flat + flat + flat + struct.pack('<3f', 1, 0, 0) + struct.pack('<H', 0)) * 2, 'wb')
    write('bad/unknown_format.xyz', '0 0 0\n1 0 0\n0 1 0\n')
    write('bad/truncated.glb', glb(*s1, {})[:300], 'wb')


if __name__ == '__main__':
    main()
