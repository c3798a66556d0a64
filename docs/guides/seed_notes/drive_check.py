# Numerical check of drive_spec.md formulas (reference values).
import numpy as np
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq
from scipy.special import lambertw

DB, DN = 0.020, 0.042            # m
nmin, nmax = 12000/60, 15000/60  # rev/s
Tc, Tn = 10.0, 5.0               # s  layer, interlayer
K, T, tau = 30.0, 2.0, 0.5       # (rev/s)/V, s, s
kg, rmin = 100.0, 0.050          # V/m, m
Kn = (nmax-nmin)/(DN-DB); n1 = (DN*nmin-DB*nmax)/(DN-DB)
Delta = nmax-nmin-n1*np.log(nmax/nmin)
P = Tc+Tn; w = 2*np.pi/P
g1 = Delta/(Kn**2*Tc); g2 = Delta/(Kn**2*Tn)
nbar = (nmax+nmin-2*n1)*(nmax-nmin)/(2*Delta)
print("Kn",Kn,"n1",n1,"(rpm",n1*60,") Delta",Delta,"g1",g1,"g2",g2,"nbar rpm",nbar*60)
def n0(t):
    t = t % P
    if t < Tn:  c = nmin - n1*np.log(nmin) + Delta*t/Tn
    else:       c = nmax - n1*np.log(nmax) - Delta*(t-Tn)/Tc
    return brentq(lambda n: n-n1*np.log(n)-c, nmin*(1-1e-12), nmax*(1+1e-12), xtol=1e-13)
def n0_lw(t):
    t = t % P
    c = (nmin - n1*np.log(nmin) + Delta*t/Tn) if t < Tn else (nmax - n1*np.log(nmax) - Delta*(t-Tn)/Tc)
    # n = -n1 W(-exp(-c/n1)/n1); n1>0 -> branch -1
    br = -1 if n1 > 0 else 0
    return float(np.real(-n1*lambertw(-np.exp(-c/n1)/n1, br)))
for t in [0, 1.3, 5, 7.7, 14.9]:
    print("t",t,"n0 rpm",n0(t)*60, "lambertW", n0_lw(t)*60)
# winding ODE check: d*dd/dt = g*n with d=(n-n1)/Kn  -> check via finite diff
for t,g in [(2.0,g2),(9.0,-g1)]:
    h=1e-4; d=lambda s:(n0(s)-n1)/Kn
    print("ODE resid", d(t)*(d(t+h)-d(t-h))/(2*h) - g*n0(t))
# Fourier coefficients via n-substitution (smooth integrands)
def coef(k):
    # interlayer: t = Tn*(n-nmin-n1 ln(n/nmin))/Delta, dt = Tn/Delta*(1-n1/n) dn
    ti = lambda n: Tn*(n-nmin-n1*np.log(n/nmin))/Delta
    tl = lambda n: Tn + Tc*(nmax-n-n1*np.log(nmax/n))/Delta
    fa = lambda n: n*(np.cos(k*w*ti(n))*Tn + np.cos(k*w*tl(n))*Tc)*(1-n1/n)/Delta
    fb = lambda n: n*(np.sin(k*w*ti(n))*Tn + np.sin(k*w*tl(n))*Tc)*(1-n1/n)/Delta
    a = 2/P*quad(fa,nmin,nmax,epsabs=1e-12,limit=200)[0]
    b = 2/P*quad(fb,nmin,nmax,epsabs=1e-12,limit=200)[0]
    return a,b
a0,_ = coef(0); print("a0/2 rpm", a0/2*60, " nbar rpm", nbar*60)
# cross-check by direct time quadrature
tt = np.linspace(0,P,30001); nn = np.array([n0(x) for x in tt])
for k in [1,2,3,5,10,20]:
    a,b = coef(k)
    ad = 2/P*np.trapezoid(nn*np.cos(k*w*tt),tt); bd = 2/P*np.trapezoid(nn*np.sin(k*w*tt),tt)
    C = np.hypot(a,b); psi = np.arctan2(a,b)
    gain = np.sqrt(1+(k*w*T)**2)/K; lead = k*w*tau+np.arctan(k*w*T)
    print(f"k={k:2d} a={a*60:9.3f} b={b*60:9.3f} rpm (direct {ad*60:9.3f},{bd*60:9.3f}) C={C*60:8.3f} rpm psi={psi:7.4f} "
          f"|1/W|*K={gain*K:6.3f} lead={lead:6.4f} rad  r-amp={C*gain/kg*1e3:7.4f} mm")
# compensated cam, m harmonics
m = 40
cs = [coef(k) for k in range(1,m+1)]
def r_of_t(t, m=m):
    s = rmin + (a0/2-nmin)/(K*kg)
    for k,(a,b) in enumerate(cs[:m],1):
        C=np.hypot(a,b); psi=np.arctan2(a,b)
        s += C*np.sqrt(1+(k*w*T)**2)/(K*kg)*np.sin(k*w*t+psi+k*w*tau+np.arctan(k*w*T))
    return s
def r_exact(t):  # time-domain exact, ideal (full series)
    h=1e-5; tp=t+tau
    dn=(n0(tp+h)-n0(tp-h))/(2*h)
    return rmin + ((n0(tp)+T*dn)/K - nmin/K)/kg
ts=np.linspace(0,P,601)
rr=np.array([r_of_t(x) for x in ts]); re=np.array([r_exact(x) for x in ts])
print("r trunc m=40: min %.3f mm max %.3f mm ; exact min %.3f max %.3f mm"%(rr.min()*1e3,rr.max()*1e3,re.min()*1e3,re.max()*1e3))
for x in [1.0,3.0,8.0,12.0]:
    print("t",x,"r40",r_of_t(x)*1e3,"rexact",r_exact(x)*1e3)
# slopes at reversals
print("dn/dt interlayer start", g2*Kn*nmin/DB*60,"rpm/s; layer end",-g1*Kn*nmin/DB*60,
      "; at nmax: inter",g2*Kn*nmax/DN*60,"layer",-g1*Kn*nmax/DN*60)
# closed-loop check: drive the DDE with exact compensated input, compare to n0
fcam = 2*np.pi/(nbar*P); print("f_rad (rad per spindle rev)", fcam, " spindle revs per double stroke", nbar*P)
# DDE test: T y' + y = K u(t-tau), u = sin
A,om=1.0,0.7
sol=solve_ivp(lambda t,y:[(-y[0]+K*(A*np.sin(om*(t-tau)) if t>=tau else 0.0))/T],[0,20],[0.0],max_step=1e-3,rtol=1e-10,atol=1e-12,dense_output=True)
def yex(t):
    if t<tau: return 0.0
    s=t-tau; return K*A/(1+(om*T)**2)*(np.sin(om*s)-om*T*np.cos(om*s)+om*T*np.exp(-s/T))
print("DDE max err", max(abs(sol.sol(x)[0]-yex(x)) for x in np.linspace(0,20,2001)))
# closed loop: u = U3 + kg*(r(t)-rmin) through K e^{-s tau}/(Ts+1); steady state vs truncated n0
U3 = nmin/K
def n_trunc(t, m=m):
    s=a0/2
    for k,(a,b) in enumerate(cs[:m],1): s+=a*np.cos(k*w*t)+b*np.sin(k*w*t)
    return s
sol=solve_ivp(lambda t,y:[(-y[0]+K*(U3+kg*(r_of_t(t-tau)-rmin)))/T],[0,6*P],[nbar],max_step=0.01,rtol=1e-9,atol=1e-9,dense_output=True)
tt2=np.linspace(5*P,6*P,301)
print("closed-loop max |n - n_trunc| rpm:", max(abs(sol.sol(x)[0]-n_trunc(x))*60 for x in tt2),
      " max |n - n0| rpm:", max(abs(sol.sol(x)[0]-n0(x))*60 for x in tt2))
# uncompensated (cam = scaled n0): error
sol2=solve_ivp(lambda t,y:[(-y[0]+n0(t-tau))/T],[0,6*P],[nbar],max_step=0.01,rtol=1e-9,atol=1e-9,dense_output=True)
print("uncompensated max |n - n0| rpm:", max(abs(sol2.sol(x)[0]-n0(x))*60 for x in tt2))
print("jumps of ideal r at reversals (mm): at nmin", T*(g2+g1)*Kn*nmin/DB/(K*kg)*1e3, " at nmax", T*(g2+g1)*Kn*nmax/DN/(K*kg)*1e3)
