"""What the Python BSDFs of gltf_metal.py and tessera_phong.py share: a one-sided reflection
BSDF for Mitsuba 3 defined by two methods of a subclass,

* `_f_cos(wi, wo)`: (f · cosθo, the density with which `_direction` draws wo), both 0 unless
  wi and wo are above the surface (local directions, Mitsuba's naming: wi toward the viewer);
* `_direction(wi, sample1, sample2)`: a direction wo drawn with that density.

`sample` returns the weight f · cosθo / pdf (0 where the density is 0, e.g. below the horizon);
`eval`, `pdf` and `eval_pdf` evaluate `_f_cos`. `register(name, define)` makes such a plugin
known to Mitsuba once per process; call it after `mi.set_variant`.
"""

from __future__ import annotations

_registered: set[str] = set()


def register(name: str, define) -> None:
    """Registers the plugin `name` whose class `define(Base, mi, dr)` returns, Base being the
    class below; a second call with the same name does nothing."""
    if name in _registered:
        return
    _registered.add(name)
    import drjit as dr
    import mitsuba as mi

    cls = define(base(mi, dr), mi, dr)
    mi.register_bsdf(name, lambda props: cls(props))


def base(mi, dr):
    class ReflectionBsdf(mi.BSDF):
        def __init__(self, props, flags):
            mi.BSDF.__init__(self, props)
            self.m_components = [flags]
            self.m_flags = flags

        def sample(self, ctx, si, sample1, sample2, active):
            wo = self._direction(si.wi, sample1, sample2)
            value, pdf = self._f_cos(si.wi, wo)
            bs = mi.BSDFSample3f()
            bs.wo, bs.pdf, bs.eta = wo, pdf, 1.0
            bs.sampled_component = mi.UInt32(0)
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            ok = active & (pdf > 0.0)
            return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

        def eval(self, ctx, si, wo, active):
            return self._f_cos(si.wi, wo)[0]

        def pdf(self, ctx, si, wo, active):
            return self._f_cos(si.wi, wo)[1]

        def eval_pdf(self, ctx, si, wo, active):
            return self._f_cos(si.wi, wo)

    return ReflectionBsdf
