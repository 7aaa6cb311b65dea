"""A lighting model: a diffuse lobe plus a specular lobe, a Fresnel term and a workflow.

Presets carry the study's shader names; GROUPS lays them out as its figures do. A Model
holds its Lobe objects, so code downstream never looks a lobe up by id; models of the
user's lobes come from a clshade.models.registry.Registry.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from clshade.errors import ClshadeError
from clshade.models.lobe import Lobe, builtin_lobes

FRESNELS = ("schlick", "dielectric", "conductor")
WORKFLOWS = ("metallic", "kdks")
NONE = "none"


@dataclass(frozen=True)
class Model:
    """A lighting model: f = k_d·diffuse_color·f_d + k_s·f_s (see kernels/compose.h).

    `lobes` are the Lobe objects of `diffuse` and `specular`, in that order. Given lobes are
    taken by id (any the ids do not name are dropped, so `replace(model, diffuse=NONE)` keeps
    the specular one); an id without a given lobe must be a built-in one."""
    diffuse: str                  # a diffuse lobe id or "none"
    specular: str                 # a specular lobe id or "none"
    fresnel: str = "schlick"
    workflow: str = "metallic"
    name: str = field(default="", compare=False)
    lobes: tuple[Lobe, ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        given = {lobe.id: lobe for lobe in self.lobes}
        chosen = []
        for ident in (self.diffuse, self.specular):
            if ident == NONE:
                continue
            lobe = given.get(ident) or builtin_lobes().get(ident)
            if lobe is None:
                raise ClshadeError(f"model {self.diffuse}+{self.specular}: {ident!r} is not a built-in lobe "
                                   f"and no Lobe was given for it (resolve the model through a Registry)")
            chosen.append(lobe)
        object.__setattr__(self, "lobes", tuple(chosen))

    @property
    def id(self) -> str:
        """Canonical id: `diffuse+specular`, with non-default Fresnel/workflow appended."""
        parts = [p for p in (self.diffuse, self.specular) if p != NONE] or [NONE]
        text = "+".join(parts)
        if self.fresnel != "schlick" and self.uses_fresnel:
            text += f"@{self.fresnel}"
        if self.workflow != default_workflow(self.specular_lobe):
            text += f"/{self.workflow}"
        return text

    @property
    def label(self) -> str:
        return self.name or self.id

    @property
    def specular_lobe(self) -> Lobe | None:
        return self.lobes[-1] if self.specular != NONE else None

    @property
    def uses(self) -> frozenset[str]:
        used: set[str] = set()
        for lobe in self.lobes:
            used |= lobe.uses
        if self.workflow == "kdks":
            used |= {"kd", "ks", "ka"}
            if self.specular != NONE:   # F0 = ((ior − 1)/(ior + 1))²: Schlick's F and the ambient's k_s·F0 (compose.h)
                used.add("ior")
        else:
            used.add("metallic")
        if "fresnel" in used:
            used |= {"dielectric": {"ior"}, "conductor": {"eta", "k"}, "schlick": {"f90"}}[self.fresnel]
        return frozenset(used)

    @property
    def is_users(self) -> bool:
        """Some lobe is the user's: no Python formula; the float64 reference is the lobe's
        double-precision device build (clshade.verify.reference.device_f64)."""
        return any(lobe.is_users for lobe in self.lobes)

    @property
    def uses_fresnel(self) -> bool:
        return any("fresnel" in lobe.uses for lobe in self.lobes)

    @property
    def family(self) -> str:
        """The study's category: the specular lobe's family, or diffuse."""
        specular = self.specular_lobe
        return specular.family if specular is not None else "diffuse"

    def with_options(self, fresnel: str | None = None, workflow: str | None = None) -> "Model":
        return replace(self, fresnel=fresnel or self.fresnel, workflow=workflow or self.workflow)


def default_workflow(specular: Lobe | None) -> str:
    """Empirical lobes use the study's k_d + k_s = 1 rule, the rest metallic-roughness."""
    if specular is not None and specular.family == "empirical":
        return "kdks"
    return "metallic"


# The study's shaders by name. Diffuse presets have no specular lobe; the
# empirical and microfacet presets pair their lobe with Lambert, as the study does.
PRESETS: dict[str, tuple[str, str, str]] = {
    "lambert": ("Lambert", "lambert", NONE),
    "oren_nayar": ("Oren–Nayar", "oren_nayar", NONE),
    "burley": ("Burley", "burley", NONE),
    "phong": ("Phong", "lambert", "phong"),
    "phong_normalized": ("Normalized Phong", "lambert", "phong_normalized"),
    "blinn_phong": ("Blinn–Phong", "lambert", "blinn_phong"),
    "blinn_phong_normalized": ("Normalized Blinn–Phong", "lambert", "blinn_phong_normalized"),
    "cook_torrance": ("Cook–Torrance", "lambert", "cook_torrance"),
    "walter_ggx": ("Walter GGX", "lambert", "walter_ggx"),
    "ggx_correlated": ("GGX height-correlated", "lambert", "ggx_correlated"),
}

# The study's groups, as its figures lay them out.
GROUPS: dict[str, tuple[str, ...]] = {
    "diffuse": ("lambert", "oren_nayar", "burley"),
    "empirical": ("phong", "phong_normalized", "blinn_phong", "blinn_phong_normalized"),
    "microfacet": ("cook_torrance", "walter_ggx", "ggx_correlated"),
}


def preset(name: str) -> Model:
    label, diffuse, specular = PRESETS[name]
    workflow = default_workflow(builtin_lobes()[specular] if specular != NONE else None)
    return Model(diffuse, specular, "schlick", workflow, name=label)


def presets() -> list[Model]:
    return [preset(p) for p in PRESETS]
