// Runs the open ASTM/AAMA parser (ksons/astm-parser, copied beside this file by the test)
// on each DXF file given and prints one JSON array: per file the pieces with, per size,
// the boundary, internal lines, turn and curve points, notches and grain lines as point
// lists, and every diagnostic with the layer, type and (for a point) position of the entity
// it is about.
import * as fs from 'fs';
import { ASTMParser } from './src/index.js';

const out: any[] = [];
for (const file of process.argv.slice(2)) {
  const parser = new ASTMParser();
  try {
    const res = await parser.parseStream(fs.createReadStream(file, { encoding: 'utf8' }));
    const data = res.data;
    const pieces = data.pieces.map((pc: any) => {
      const points = (shapes: any) => Object.fromEntries(Object.entries(shapes).map(([size, s]: [string, any]) =>
        [size, { lengths: s.lengths, points: s.vertices.map((i: number) => [pc.vertices[2 * i], pc.vertices[2 * i + 1]]) }]));
      return { name: pc.name, boundary: points(pc.shapes), internal: points(pc.internalShapes),
               turn: points(pc.turnPoints), curve: points(pc.curvePoints), notches: points(pc.notches),
               grain: points(pc.grainLines) };
    });
    out.push({ file, ok: true, asset: data.asset, style: data.style, sizes: data.sizes, pieces,
               diagnostics: res.diagnostics.map((g: any) => ({ severity: g.severity, message: g.message,
                 layer: g.data?.layer ?? null, type: g.data?.type ?? null,
                 position: g.data?.position ?? null })) });
  } catch (e) {
    out.push({ file, ok: false, error: String(e) });
  }
}
console.log(JSON.stringify(out));
