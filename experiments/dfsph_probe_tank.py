import numpy as np, jax, jax.numpy as jnp
import rockjax
from rockjax import scenes
from rockjax.step import prime, make_step
for gz in [0.0, -9.81]:
    sc = scenes.hydrostatic_tank(dx=0.02, depth=0.2, periodic_xy=True, scheme=rockjax.DFSPH())
    cfg, params, st = sc.config, sc.params, sc.state
    params = params.replace(gravity=jnp.asarray([0.0, 0.0, gz], params.gravity.dtype))
    cfg = cfg.replace(rebuild_every=1)
    st = prime(st, params, cfg); step = jax.jit(make_step(cfg))
    x0 = np.asarray(st.particles.x)[np.argsort(np.asarray(st.particles.pid))]
    vr=[]
    for k in range(60):
        st = step(st, params); P = st.particles; fl = np.asarray(P.kind)==0
        vr.append(np.sqrt((np.asarray(P.v)[fl]**2).sum(1).mean()))
    P = st.particles; o=np.argsort(np.asarray(P.pid)); v=np.asarray(P.v)[o]; fl=np.asarray(P.kind)[o]==0
    print("g", gz, np.round(np.array(vr)[[0,5,10,20,40,59]],5))
    for zl in np.unique(np.round(x0[fl,2],3)):
        m = fl & np.isclose(x0[:,2], zl); print("  z %.2f vz %+.4f vxy %.4f"%(zl, v[m,2].mean(), np.sqrt((v[m,:2]**2).sum(1).mean())))
