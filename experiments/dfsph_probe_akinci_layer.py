import numpy as np, jax, jax.numpy as jnp
import rockjax
from rockjax import scenes
from rockjax.sph.kernels import WendlandC2
from rockjax.step import prime, make_step
sc = scenes.hydrostatic_tank(dx=0.02, depth=0.2, periodic_xy=True, scheme=rockjax.DFSPH())
cfg, params, st = sc.config, sc.params, sc.state
P = st.particles; x = np.asarray(P.x); kind = np.asarray(P.kind); vol = np.asarray(P.vol).copy()
wall = kind == 1; first = wall & (x[:,2] > -0.02)
h = float(params.fluid.h); L = 0.2
xb = x[first]
d = xb[:,None,:]-xb[None,:,:]; d[...,:2] -= L*np.round(d[...,:2]/L)
r = np.linalg.norm(d, axis=-1)
psi = 1.0/np.asarray(WendlandC2().w(jnp.asarray(r), h)).sum(1)
vol[wall] = 0.0; vol[first] = psi * (np.asarray(P.vol)[0] / 1.0)  # Akinci: Psi_b = rho0 / sum W; V_b = 1 / sum W
# lattice_sum divides all volumes; undo for walls by pre-multiplying
from rockjax.sph.dfsph import lattice_sum
ls = float(lattice_sum(jnp.asarray(vol[0]), h, WendlandC2()))
vol[first] = psi * ls
print("psi/dx^3", psi.mean()/0.02**3, "n first", first.sum())
st = st.replace(particles=P.replace(vol=jnp.asarray(vol, P.vol.dtype)))
cfg = cfg.replace(rebuild_every=1)
st = prime(st, params, cfg); step = jax.jit(make_step(cfg))
vr=[]
for k in range(100):
    st = step(st, params); Q = st.particles; fl = np.asarray(Q.kind)==0
    vr.append(np.sqrt((np.asarray(Q.v)[fl]**2).sum(1).mean()))
print(np.round(np.array(vr)[[0,5,10,20,40,60,80,99]],4), int(st.status), "zmin", np.asarray(Q.x)[fl,2].min())
