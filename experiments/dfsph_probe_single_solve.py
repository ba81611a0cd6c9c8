import sys, numpy as np, jax, jax.numpy as jnp
OMEGA=float(sys.argv[1])
import rockjax
from rockjax import scenes
from rockjax.sph import dfsph
from rockjax.step import prime
sc = scenes.hydrostatic_tank(dx=0.02, depth=0.2, scheme=rockjax.DFSPH())
cfg, params, st = sc.config, sc.params, sc.state
st = prime(st, params, cfg); P=st.particles
geo = dfsph.geometry(P.x, P.kind, P.vol, st.nbrs, params, cfg)
nf=cfg.n_fluid; dt=cfg.dt; fl=np.asarray(P.kind)[:nf]==0
v = P.v.at[:nf, 2].add(-9.81*dt)
kap = jnp.zeros(nf)
z = np.asarray(P.x)[:nf,2]
for it in range(400):
    e = jnp.maximum(geo.rho + dt*dfsph.divergence(geo, v) - 1, 0)
    es = geo.rho + dt*dfsph.divergence(geo, v) - 1
    k = OMEGA*e*geo.factor/dt**2
    a = dfsph.pressure_acceleration(geo, k)
    v = v.at[:nf].add(dt*a); kap = kap+k
    if it in (0,1,2,5,10,20,50,100,200,399):
        vz = np.asarray(v)[:nf,2]
        print(it, "mean e %.2e  signed %.2e  max %.2e"%(float(e.mean()), float(es.mean()), float(e.max())), "vz mean %.3e min %.3e max %.3e"%(vz.mean(), vz.min(), vz.max()),
              "p/ref mid", float(kap[(z>0.09)&(z<0.11)].mean()*1000/(1000*9.81*0.1)))
vz = np.asarray(v)[:nf,2]; kk=np.asarray(kap)
for zl in np.unique(np.round(z,3)):
    m = np.isclose(z, zl)
    print("z %.3f vz %.3e kappa*rho0/(rho g (zs-z)) %.3f  rho %.4f factor %.3e"%(zl, vz[m].mean(), kk[m].mean()*1000/(1000*9.81*(0.2-zl)), float(np.asarray(geo.rho)[m].mean()), float(np.asarray(geo.factor)[m].mean())))
