/* The floor of a finest-level Jacobi sweep in C (issue 16 item 2, session 34): gcc's code for
 * the product's sweep beside the STREAM triad, to tell numba's code generation from the
 * hardware's limit.
 *
 *   gcc -Ofast -march=native -fopenmp -o /tmp/sweep benchmarks/sweep_floor_c.c
 *   OMP_NUM_THREADS=2 /tmp/sweep 10      # rounds; OMP_NUM_THREADS=1 for one core
 *
 * Per round (200^3 float32 iterate, uint8 diagonal, float32 right-hand side and output, the
 * 13 B per cell of benchmarks/bench_sweep_floor.py): the triad (best of 3, 12 B per element,
 * 40 M elements), then ns per cell (best of 5) and the multiple of the triad time of 13 B per
 * cell for
 *   sweep  the bare flat 3-D sweep (no wrap, no dot; bench_sweep_floor.py's "3d"),
 *   pairs  two x-planes per loop,
 *   full   the product's jacobi: periodic in x, y and z (row pointers, scalar row ends) and
 *          the float64 dot b . xnew summed in the same loop.
 * -Ofast: numba's kernels are compiled with fastmath too (the float64 dot then vectorises).
 * Results: benchmarks/RESULTS.md, "Session 34 lead".
 */
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include <omp.h>
#include <string.h>
#define N 200
static double now(){return omp_get_wtime();}
/* bare 3-D Jacobi: out = x + (b - (d*x - sum6)) * om/d  (d>0 assumed as float of uint8) */
static void sweep(const float*restrict x,const uint8_t*restrict d,const float*restrict b,float*restrict out,int n){
  size_t pl=(size_t)n*n;
  #pragma omp parallel for schedule(static)
  for(int i=0;i<n;i++){
    const float*xm=x+(size_t)((i+n-1)%n)*pl,*xp=x+(size_t)((i+1)%n)*pl,*x0=x+(size_t)i*pl;
    const uint8_t*dd=d+(size_t)i*pl; const float*bb=b+(size_t)i*pl; float*oo=out+(size_t)i*pl;
    for(size_t t=n;t<pl-n;t++){
      float sm=xm[t]+xp[t]+x0[t-n]+x0[t+n]+x0[t-1]+x0[t+1];
      float dv=(float)dd[t];
      float ax=dv*x0[t]-sm;
      oo[t]=x0[t]+(bb[t]-ax)*(0.8f/ (dv+1.0f));
    }
  }
}
/* pairs: two planes per loop */
static void sweep2(const float*restrict x,const uint8_t*restrict d,const float*restrict b,float*restrict out,int n){
  size_t pl=(size_t)n*n;
  #pragma omp parallel for schedule(static)
  for(int i=0;i<n;i+=2){
    const float*xm=x+(size_t)((i+n-1)%n)*pl,*x0=x+(size_t)i*pl,*x1=x+(size_t)(i+1)*pl,*xp=x+(size_t)((i+2)%n)*pl;
    const uint8_t*d0=d+(size_t)i*pl,*d1=d0+pl; const float*b0=b+(size_t)i*pl,*b1=b0+pl; float*o0=out+(size_t)i*pl,*o1=o0+pl;
    for(size_t t=n;t<pl-n;t++){
      float s0=xm[t]+x1[t]+x0[t-n]+x0[t+n]+x0[t-1]+x0[t+1];
      float s1=x0[t]+xp[t]+x1[t-n]+x1[t+n]+x1[t-1]+x1[t+1];
      float dv0=(float)d0[t], dv1=(float)d1[t];
      o0[t]=x0[t]+(b0[t]-(dv0*x0[t]-s0))*(0.8f/(dv0+1.0f));
      o1[t]=x1[t]+(b1[t]-(dv1*x1[t]-s1))*(0.8f/(dv1+1.0f));
    }
  }
}

/* product-like: periodic in all three directions, row pointers, float64 dot of b.out */
static double sweep_full(const float*restrict x,const uint8_t*restrict d,const float*restrict b,float*restrict out,int n){
  size_t pl=(size_t)n*n; double tot=0;
  #pragma omp parallel for schedule(static) reduction(+:tot)
  for(int i=0;i<n;i++){
    const float*xm=x+(size_t)((i+n-1)%n)*pl,*xp=x+(size_t)((i+1)%n)*pl,*x0=x+(size_t)i*pl;
    double s=0;
    for(int j=0;j<n;j++){
      size_t r=(size_t)j*n, rm=(size_t)((j+n-1)%n)*n, rp=(size_t)((j+1)%n)*n;
      const float*a=x0+r,*am=x0+rm,*ap=x0+rp,*em=xm+r,*ep=xp+r; const uint8_t*dd=d+(size_t)i*pl+r;
      const float*bb=b+(size_t)i*pl+r; float*oo=out+(size_t)i*pl+r;
      float s32=0;
      for(int k=1;k<n-1;k++){
        float sm=em[k]+ep[k]+am[k]+ap[k]+a[k-1]+a[k+1];
        float dv=(float)dd[k]; float ax=dv*a[k]-sm;
        float v=a[k]+(bb[k]-ax)*(0.8f/(dv+1.0f)); oo[k]=v; s+=(double)bb[k]*(double)v;
      }
      for(int e=0;e<2;e++){int k=e?n-1:0; int km=(k+n-1)%n,kp=(k+1)%n;
        float sm=em[k]+ep[k]+am[k]+ap[k]+a[km]+a[kp]; float dv=(float)dd[k]; float ax=dv*a[k]-sm;
        float v=a[k]+(bb[k]-ax)*(0.8f/(dv+1.0f)); oo[k]=v; s+=(double)bb[k]*(double)v;}
    }
    tot+=s;
  }
  return tot;
}
static void triad(float*restrict a,const float*restrict b,const float*restrict c,size_t m){
  #pragma omp parallel for schedule(static)
  for(size_t t=0;t<m;t++) a[t]=b[t]+1.5f*c[t];
}
int main(int argc,char**argv){
  int rounds=argc>1?atoi(argv[1]):10; size_t m=(size_t)N*N*N;
  float*x=aligned_alloc(64,m*4),*b=aligned_alloc(64,m*4),*o=aligned_alloc(64,m*4);
  uint8_t*d=aligned_alloc(64,m);
  size_t tm=40000000; float*ta=aligned_alloc(64,tm*4),*tb=aligned_alloc(64,tm*4),*tc=aligned_alloc(64,tm*4);
  for(size_t t=0;t<m;t++){x[t]=t%7;b[t]=1;o[t]=0;d[t]=t%5+1;}
  for(size_t t=0;t<tm;t++){ta[t]=0;tb[t]=1;tc[t]=2;}
  for(int r=0;r<rounds;r++){
    double best=1e9; for(int k=0;k<3;k++){double t0=now();triad(ta,tb,tc,tm);double t1=now()-t0;if(t1<best)best=t1;}
    double bw=12.0*tm/best/1e9;
    double s1=1e9,s2=1e9;
    for(int k=0;k<5;k++){double t0=now();sweep(x,d,b,o,N);double t1=now()-t0;if(t1<s1)s1=t1;}
    for(int k=0;k<5;k++){double t0=now();sweep2(x,d,b,o,N);double t1=now()-t0;if(t1<s2)s2=t1;}
    double s3=1e9; for(int k=0;k<5;k++){double t0=now();sweep_full(x,d,b,o,N);double t1=now()-t0;if(t1<s3)s3=t1;}
    double ideal=13.0*m/(bw*1e9);
    printf("triad %.1f GB/s  sweep %.3f ns %.2fx  pairs %.3f ns %.2fx  full %.3f ns %.2fx\n",bw,s1/m*1e9,s1/ideal,s2/m*1e9,s2/ideal,s3/m*1e9,s3/ideal);
    fflush(stdout);
  }
  return 0;
}
