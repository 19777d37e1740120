#!/usr/bin/env python3
"""Rewrite flat `RenderSettings { photons: 256, medium_steps: 32, ..base }` literals into sections
(issue 40): `RenderSettings { photons: PhotonSettings { count: 256, ..base.photons }, medium:
MediumSettings { steps: 32, ..base.medium }, ..base }`. Companion of tools/rename_settings.sh
(which renames field accesses). Usage: tools/rename_settings_literals.py FILE..."""
import re
import sys

FIELDS = {
    'photons': ('photons', 'count'), 'technique': ('photons', 'technique'), 'tracer': ('photons', 'tracer'),
    'max_depth': ('photons', 'max_depth'), 'splat': ('photons', 'splat'), 'splat_sigma': ('photons', 'splat_sigma'),
    'caustic_map_size': ('photons', 'caustic_map_size'), 'photon_memory': ('photons', 'memory'),
    'dielectric_reflection': ('photons', 'reflection'), 'internal_reflection': ('photons', 'internal_reflection'),
    'residual_branches': ('photons', 'residual'),
    'base_grid': ('adaptive', 'base_grid'), 'max_error_tolerance': ('adaptive', 'error_tolerance'),
    'error_check_grid': ('adaptive', 'check_grid'), 'quad_linearity': ('adaptive', 'quad_linearity'),
    'shadow_map_size': ('shading', 'shadow_map_size'), 'spill_faces': ('shading', 'spill_faces'),
    'tessellation': ('shading', 'tessellation'),
    'medium_steps': ('medium', 'steps'), 'medium_light_steps': ('medium', 'light_steps'),
    'medium_bounce_grid': ('medium', 'bounce_grid'), 'medium_bounce_steps': ('medium', 'bounce_steps'),
    'medium_beyond_specular': ('medium', 'beyond_specular'),
    'env_lights': ('environment', 'lights'), 'env_split': ('environment', 'split'), 'env_taps': ('environment', 'taps'),
    'first_hit_from_buffer': ('testing', 'first_hit_from_buffer'),
    'error_skip_hopeless': ('testing', 'error_skip_hopeless'),
    'light_second_layer': ('testing', 'light_second_layer'), 'shading_tiles': ('testing', 'shading_tiles'),
}
WHOLE = {'beams', 'surface_caustics', 'photons_section', 'adaptive', 'shading', 'medium', 'environment', 'testing'}
TYPES = {'photons': 'PhotonSettings', 'adaptive': 'AdaptiveSettings', 'shading': 'ShadingSettings',
         'medium': 'MediumSettings', 'environment': 'EnvironmentSettings', 'testing': 'TestingSettings'}
ORDER = ['photons', 'adaptive', 'shading', 'medium', 'environment', 'testing']


def split_top(body):
    items, depth, cur, i, s = [], 0, '', 0, body
    while i < len(s):
        ch = s[i]
        if ch == '"':
            j = i + 1
            while s[j] != '"':
                j += 2 if s[j] == '\\' else 1
            cur += s[i:j + 1]
            i = j + 1
            continue
        if ch == '/' and s[i:i + 2] == '//':
            j = s.index('\n', i)
            cur += s[i:j]
            i = j
            continue
        if ch in '([{':
            depth += 1
        elif ch in ')]}':
            depth -= 1
        if ch == ',' and depth == 0:
            items.append(cur)
            cur = ''
        else:
            cur += ch
        i += 1
    if cur.strip():
        items.append(cur)
    return items


def rewrite(body, prefix):
    items = split_top(body)
    base = None
    sections = {k: [] for k in ORDER}
    outer = []
    for it in items:
        t = it.strip()
        comments = '\n'.join(l for l in t.split('\n') if l.strip().startswith('//'))
        code = '\n'.join(l for l in t.split('\n') if not l.strip().startswith('//')).strip()
        if code.startswith('..'):
            base = code[2:].strip()
            continue
        m = re.match(r'^(\w+)\s*(?::\s*(.*))?$', code, re.S)
        if not m:
            raise SystemExit(f'cannot parse item {code!r}')
        name, expr = m.group(1), m.group(2)
        if name in FIELDS and not (name == 'photons' and expr and re.search(r'PhotonSettings', expr)):
            sec, new = FIELDS[name]
            expr = expr if expr is not None else name
            sections[sec].append((comments, f'{new}: {expr}' if new != expr else new))
        else:
            outer.append((comments, code))
    if base is None:
        sbase = lambda sec: 'Default::default()'
        obase = None
    elif re.fullmatch(r'(Default::default\(\)|(caustics::(render|settings)::)?RenderSettings::default\(\))', base):
        sbase = lambda sec: 'Default::default()'
        obase = base
    else:
        b = re.sub(r'\.clone\(\)$', '', base)
        sbase = lambda sec: f'{b}.{sec}'
        obase = base
    out = []
    for sec in ORDER:
        if sections[sec]:
            fields = ', '.join((c + '\n' if c else '') + f for c, f in sections[sec])
            out.append(f'{sec}: {prefix}{TYPES[sec]} {{ {fields}, ..{sbase(sec)} }}')
    for c, code in outer:
        out.append((c + '\n' if c else '') + code)
    if obase is not None:
        out.append(f'..{obase}')
    elif any(sections.values()):
        out.append('..Default::default()')
    return ' ' + ', '.join(out) + ' '


def process(path, prefix):
    s = open(path).read()
    out, pos = '', 0
    for m in re.finditer(r'RenderSettings\s*\{', s):
        if m.start() < pos:
            continue
        pre = s[max(0, m.start() - 40):m.start()]
        if re.search(r'(struct|impl|for|->)\s*&?\s*(\w+::)*$', pre):
            continue
        i, d = m.end(), 1
        while d:
            ch = s[i]
            if ch in '{([':
                d += 1
            elif ch in '})]':
                d -= 1
            i += 1
        body = s[m.end():i - 1]
        out += s[pos:m.end()] + rewrite(body, prefix) + '}'
        pos = i
    out += s[pos:]
    if out != s:
        open(path, 'w').write(out)


if __name__ == '__main__':
    for p in sys.argv[1:]:
        prefix = 'crate::settings::' if '/crates/caustics/src/' in '/' + p else 'caustics::settings::'
        process(p, prefix)
