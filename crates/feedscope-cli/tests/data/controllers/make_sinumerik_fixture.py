#!/usr/bin/env python3
"""Write sinumerik_2axes_structure.xml: a small SINUMERIK Operate servo trace in the structure of
a real one (see README.md), with made-up values. Deterministic; run from this folder:

    python3 make_sinumerik_fixture.py > sinumerik_2axes_structure.xml

Two axes: 1 (X, at rest) and 3 (Z, accelerating to 600 mm/min). Position every 4 ms and written
in full (IPO signals, event 1); current, following error and position setpoint every 2 ms and
written only where they change (servo signals, event 255), with a closing record at stopInc
holding every servo signal, as the control writes them. Z's current at 0.200 s is the control's
invalid mark.
"""
import math

DT = 0.002
N = 201  # records 0 .. 0.400 s
INVALID = "9223372036854775807"
CURRENT_Q = 0.006653  # the current's resolution in the real file


def z_mm(t):
    # rest until 0.05 s, 1000 mm/s^2 to 10 mm/s (at 0.06 s), then constant
    if t < 0.05:
        return 100.0
    if t < 0.06:
        return 100.0 + 0.5 * 1000.0 * (t - 0.05) ** 2
    return 100.0 + 0.05 + 10.0 * (t - 0.06)


def q(x, step):
    return round(x / step) * step


signals = [
    # (key, name, description, unitsType, dataType, event, interval, value(t) or None)
    ("s1", "/Nck/!SD/nckServoDataActCurr32 [u1, 1]", "Torque-prod. Current act. Val. i(q) (32 bit)",
     "current", "float", 255, 0.002, lambda t, k: q(0.40 + 0.004 * math.sin(7.0 * t), CURRENT_Q)),
    ("s2", "/Nck/!SEMA/measPos1 [u1, 1]", "Actual position value for measuring system 1.",
     "posn", "double", 1, 0.004, lambda t, k: 250.0 + (0.00001 if k % 3 == 0 else 0.0)),
    ("s3", "/Channel/!SEMA/aaStat [u1, 3]", "Axis status", "none", "uword", 1, 0.004,
     lambda t, k: 4.0),
    ("s4", "/Nck/!SD/nckServoDataActCurr32 [u1, 3]", "Torque-prod. Current act. Val. i(q) (32 bit)",
     "current", "float", 255, 0.002,
     lambda t, k: None if abs(t - 0.2) < 1e-9 else q(
         (0.30 if t < 0.05 else 1.20 + 0.05 * math.sin(2 * math.pi * z_mm(t) / 10.0 * 3.0)
          + (0.8 if t < 0.06 else 0.0)), CURRENT_Q)),
    ("s5", "/Nck/!SD/nckServoDataFlwErr64 [u1, 3]", "Following Error (64 bit)", "posn", "double",
     255, 0.002, lambda t, k: 0.0 if t < 0.05 else q(0.0055 if t >= 0.06 else 0.0055 * (t - 0.05) / 0.01, 0.000086)),
    ("s6", "/Nck/!SEMA/measPos1 [u1, 3]", "Actual position value for measuring system 1.",
     "posn", "double", 1, 0.004, lambda t, k: q(z_mm(t), 0.00001)),
    ("s7", "/Nck/!SEMA/measPos2 [u1, 3]", "Actual position value for measuring system 2.",
     "posn", "double", 1, 0.004, lambda t, k: q(z_mm(t) + 0.0012, 0.00001)),
    ("s8", "/Nck/!SD/nckServoDataCmdPos2ndEnc64 [u1, 3]", "Position setpoint (64 bit)", "posn",
     "double", 255, 0.002, lambda t, k: q(z_mm(t) + 0.0055 if t >= 0.05 else z_mm(t), 0.00001)),
]


def fmt(v, data_type):
    if v is None:
        return INVALID
    return str(int(v)) if data_type == "uword" else f"{v:.6f}"


def grid(interval):
    # 4 ms signals sit on the odd 2 ms ticks, as in the real file
    offset = 0.002 if interval > 0.003 else 0.0
    n = int((0.4 - offset) / interval + 1e-9) + 1
    return [(round(offset + k * interval, 6), k) for k in range(n)]


print('<?xml version="1.0" encoding="utf-8" ?>')
print('<!--XML file in the structure of a SINUMERIK Solution Line Trace, written for the feedscope tests by make_sinumerik_fixture.py-->')
print('<traceSession version="01.00.03.02">')
print('<traceCaptureSetup_V20>')
print(' <collectionSettings capacity="5.77853e+07" powerOnStart="false" atCapacity="discard" appendData="false" timeLimit="1" deferOffload="false" autoRestart="false" endless="false"/>')
print(' <sessionSettings clientPrivilegeManage="exclusive" archiveSetting="NCU" sessionName="feedscope_fixture_XZ" clientPrivilegeRead="password" expirationPeriod="0"/>')
print(' <sampleRateSettings driveSampleRate1="0.00012500" servoSampleRate="0.002" ipo2SampleRate="0.004" ipo1SampleRate="0.004"/>')
print(' <signalSettings>')
for key, name, desc, ut, dt, ev, iv, _ in signals:
    print(f'  <signal domain="NCU_1" event="{ev}" description="{desc}" displayRes="5" eventChannel="1" key="{key}" name="{name}" unitsType="{ut}" dataType="{dt}"/>')
print(' </signalSettings>')
print('</traceCaptureSetup_V20>')
print()
print('<traceDisplaySetup_V20>')
print(' <signals>')
for key, name, desc, ut, dt, ev, iv, _ in signals:
    print(f'  <signal event="{ev}" compositeDef="" name="{name}" axisDisplay="leftSide" color="00ff0000" domain="NCU_1" isReference="false" lineStyle="solid" markerStyle="none" scaleFactor="1" eventChannel="1" description="{desc}" bitMask="00000000" lineWidth="1" key="{key}" displayRes="5" plotYOption="plotSourceY" unitsType="{ut}" dataType="{dt}"/>')
print(' </signals>')
print('</traceDisplaySetup_V20>')
print()
print('<traceData dataFrames="1">')
print(' <dataFrame>')
print('  <frameHeader stopTriggerInc="0.000000" startTriggerInc="0.000000" dropOuts="0" startTime="2026-11-20T09:14:03.250Z" stopInc="0.400000"/>')
for i, (key, name, desc, ut, dt, ev, iv, _) in enumerate(signals):
    n = len(grid(iv))
    print(f'  <dataSignal domain="NCU_1" interval="{iv:.6f}" id="f{i + 1}" event="{ev}" description="{desc}" displayRes="5" eventChannel="1" datapointCount="{n}" key="{key}" name="{name}" unitsType="{ut}" dataType="{dt}"/>')
values = {}
for i, (key, name, desc, ut, dt, ev, iv, f) in enumerate(signals):
    pts = grid(iv)
    last = None
    for j, (t, k) in enumerate(pts):
        text = fmt(f(t, k), dt)
        edge = j == 0 or j == len(pts) - 1
        if ev == 255 and not edge and text == last:
            continue
        last = text
        values.setdefault(round(t * 1e6), []).append((i, text))
for us in sorted(values):
    attrs = "".join(f' f{i + 1}="{v}"' for i, v in sorted(values[us]))
    print(f'  <rec time="{us / 1e6:.6f}"{attrs}/>')
print(' </dataFrame>')
print('</traceData>')
print('</traceSession>')
